"""The job store on a real SQLite file: migrations, record lifecycle, concurrent writers."""

from __future__ import annotations

import json
import multiprocessing
from pathlib import Path

import pytest
from sqlalchemy import inspect, text

from inkmotion import store
from inkmotion.store.db import get_engine


@pytest.fixture
def db_url(tmp_path: Path) -> str:
    return f"sqlite:///{tmp_path / 'jobs.sqlite3'}"


def test_migrations_create_the_schema_matching_the_models(db_url):
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    engine = get_engine(db_url)
    assert set(inspect(engine).get_table_names()) == {"jobs", "alembic_version"}
    with engine.connect() as conn:
        assert conn.execute(text("SELECT version_num FROM alembic_version")).scalar() == "0001"
        assert compare_metadata(MigrationContext.configure(conn), store.Job.metadata) == []
        assert conn.execute(text("PRAGMA journal_mode")).scalar() == "wal"
        assert conn.execute(text("PRAGMA busy_timeout")).scalar() >= 1000
    store.upgrade(engine)  # idempotent


def test_record_lifecycle(db_url):
    spec = {"kind": "fit", "input": "text:hi", "params": {"steps": 5}}
    r = store.create_job(spec, kind="fit", queue="optimise", label="text:hi", total=5,
                         db_url=db_url)
    assert (r.status, r.attempts, r.step, r.total, r.spec) == ("queued", 0, 0, 5, spec)
    assert len(r.id) == 32 and r.created_at.tzinfo is not None
    assert store.mark_running(r.id, "w1@a", db_url)
    assert store.update_progress(r.id, 3, 5, {"mse": 0.5, "total": 1.0}, 2.0, db_url)
    mid = store.get_job(r.id, db_url)
    assert (mid.status, mid.step, mid.losses, mid.t_end, mid.worker_host, mid.attempts) == (
        "running", 3, {"mse": 0.5, "total": 1.0}, 2.0, "w1@a", 1)
    assert store.mark_running(r.id, "w2@b", db_url)  # a redelivery: a second attempt
    assert store.mark_succeeded(r.id, "/data/jobs/x/artifacts", db_url)
    done = store.get_job(r.id, db_url)
    assert (done.status, done.attempts, done.worker_host) == ("succeeded", 2, "w2@b")
    assert done.finished and done.finished_at >= done.started_at >= done.created_at
    assert done.artifact_dir == "/data/jobs/x/artifacts"
    json.dumps(done.to_dict())
    # a finished job can be neither restarted nor cancelled
    assert not store.mark_running(r.id, "w3@c", db_url)
    assert not store.mark_cancelled(r.id, db_url)
    assert not store.mark_failed(r.id, "late", db_url)


def test_cancelled_and_failed_jobs_stay_so(db_url):
    a = store.create_job({}, kind="fit", queue="optimise", db_url=db_url)
    assert store.mark_cancelled(a.id, db_url)
    assert not store.mark_running(a.id, "w1", db_url)
    assert not store.update_progress(a.id, 1, 5, db_url=db_url)
    assert store.get_job(a.id, db_url).status == "cancelled"
    b = store.create_job({}, kind="fit", queue="optimise", db_url=db_url)
    assert store.mark_running(b.id, "w1", db_url)
    assert store.mark_failed(b.id, "Bad input.", db_url)
    assert not store.mark_succeeded(b.id, "/x", db_url)
    got = store.get_job(b.id, db_url)
    assert (got.status, got.error) == ("failed", "Bad input.")


def test_list_find_and_delete(db_url):
    ids = [store.create_job({}, kind="fit", queue="optimise", db_url=db_url).id
           for _ in range(3)]
    store.mark_cancelled(ids[0], db_url)
    assert {r.id for r in store.list_jobs(db_url=db_url)} == set(ids)
    assert [r.id for r in store.list_jobs("cancelled", db_url=db_url)] == [ids[0]]
    assert store.find_job(ids[1][:10], db_url).id == ids[1]
    assert store.find_job("zzzzzz", db_url) is None
    from inkmotion.errors import SpecError

    with pytest.raises(SpecError, match="Unknown status"):
        store.list_jobs("done", db_url=db_url)
    assert store.delete_job(ids[2], db_url)
    assert store.get_job(ids[2], db_url) is None


def _hammer(db_url: str, job_id: str, n: int) -> None:
    for k in range(n):
        assert store.mark_running(job_id, f"host-{k}", db_url)
        store.update_progress(job_id, k, n, {"total": float(k)}, 1.0, db_url)
        store.create_job({}, kind="fit", queue="optimise", db_url=db_url)


def test_concurrent_writers_from_several_processes(db_url):
    """Four processes race on one job (SQLite WAL + busy_timeout): no lost update."""
    job = store.create_job({}, kind="fit", queue="optimise", db_url=db_url)
    ctx = multiprocessing.get_context("fork")
    procs = [ctx.Process(target=_hammer, args=(db_url, job.id, 25)) for _ in range(4)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
    assert [p.exitcode for p in procs] == [0, 0, 0, 0]
    assert store.get_job(job.id, db_url).attempts == 100
    assert len(store.list_jobs(limit=None, db_url=db_url)) == 101


def _first_use(db_url: str) -> None:
    get_engine(db_url)


def test_concurrent_first_use_migrates_once(tmp_path):
    url = f"sqlite:///{tmp_path / 'fresh.sqlite3'}"
    ctx = multiprocessing.get_context("fork")
    procs = [ctx.Process(target=_first_use, args=(url,)) for _ in range(3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
    assert [p.exitcode for p in procs] == [0, 0, 0]
    assert store.list_jobs(db_url=url) == []
