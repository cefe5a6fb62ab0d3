"""The job store on a real SQLite file: migrations, record lifecycle, concurrent writers."""

from __future__ import annotations

import json
import multiprocessing
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from sqlalchemy import inspect, text

from inkmotion import store
from inkmotion.store import db as store_db
from inkmotion.store.db import get_engine
from inkmotion.store.migrations import HEAD_REVISION


@pytest.fixture(scope="module")
def postgres() -> Iterator[object]:
    """A PostgreSQL server for this module (Debian's postgresql, started in a temporary
    folder on a free port; installed by `make test`); skipped where it is not installed."""
    from inkmotion.workers.local import postgres_bin_dir, start_postgres

    if postgres_bin_dir() is None:
        pytest.skip("PostgreSQL is not installed (apt-get install postgresql)")
    pytest.importorskip("psycopg")
    server = start_postgres()
    yield server
    store.dispose_engines()
    server.stop()


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """A fresh job store: a SQLite file, or a new database on the PostgreSQL server."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'jobs.sqlite3'}"
    server = request.getfixturevalue("postgres")
    return server.create_database(f"t{abs(hash(request.node.nodeid)) % 10**9}")


def test_migrations_create_the_schema_matching_the_models(db_url):
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    engine = get_engine(db_url)
    assert set(inspect(engine).get_table_names()) == {"jobs", "alembic_version"}
    with engine.connect() as conn:
        assert conn.execute(text("SELECT version_num FROM alembic_version")).scalar() == "0003"
        assert compare_metadata(MigrationContext.configure(conn), store.Job.metadata) == []
        if engine.dialect.name == "sqlite":
            assert conn.execute(text("PRAGMA journal_mode")).scalar() == "wal"
            assert conn.execute(text("PRAGMA busy_timeout")).scalar() >= 1000
    assert "metrics" in {c["name"] for c in inspect(engine).get_columns("jobs")}
    store.upgrade(engine)  # idempotent


def test_head_revision_constant_is_alembics_head():
    """The fast path compares against HEAD_REVISION: it must be the real head."""
    from alembic.script import ScriptDirectory

    heads = ScriptDirectory.from_config(store_db.alembic_config()).get_heads()
    assert heads == [HEAD_REVISION]


_OLD_ROW = text(  # a row as revision 0001 wrote it (no metrics column yet)
    "INSERT INTO jobs (id, kind, queue, status, spec, label, step, total, losses, t_end, "
    "created_at, updated_at, attempts, artifact_dir) VALUES (:id, 'fit', 'optimise', "
    "'succeeded', :spec, 'text:hi', 5, 5, :losses, 1.5, '2025-01-02 03:04:05.000000', "
    "'2025-01-02 03:04:06.000000', 1, '/data/x')")


def test_upgrade_from_0001_keeps_rows_and_adds_null_metrics(tmp_path):
    url = f"sqlite:///{tmp_path / 'old.sqlite3'}"
    old = get_engine(url, migrate=False)
    store.upgrade(old, "0001")
    with old.begin() as conn:
        conn.execute(_OLD_ROW, {"id": "a1", "spec": json.dumps({"input": "text:hi"}),
                                "losses": json.dumps({"total": 0.5})})
    assert store_db.schema_revisions(old) == ("0001",) and not store_db.schema_is_current(old)
    get_engine(url)  # a stale database: the fast path must not skip the upgrade
    assert store_db.schema_revisions(old) == (HEAD_REVISION,)
    got = store.get_job("a1", url)
    assert (got.status, got.spec, got.losses, got.t_end, got.artifact_dir, got.metrics) == (
        "succeeded", {"input": "text:hi"}, {"total": 0.5}, 1.5, "/data/x", None)
    assert got.created_at.isoformat() == "2025-01-02T03:04:05+00:00"
    with old.connect() as conn:
        assert conn.execute(text("SELECT COUNT(*) FROM jobs WHERE metrics IS NULL")).scalar() == 1


def test_downgrade_to_0001_drops_metrics_and_keeps_rows(db_url):
    from alembic import command

    engine = get_engine(db_url)
    r = store.create_job({"kind": "fit"}, kind="fit", queue="optimise", db_url=db_url)
    with engine.begin() as conn:
        cfg = store_db.alembic_config()
        cfg.attributes["connection"] = conn
        command.downgrade(cfg, "0001")
    insp = inspect(engine)
    assert "metrics" not in {c["name"] for c in insp.get_columns("jobs")}
    assert {i["name"] for i in insp.get_indexes("jobs")} == {"ix_jobs_status",
                                                             "ix_jobs_created_at"}
    with engine.connect() as conn:
        assert conn.execute(text("SELECT id FROM jobs")).scalars().all() == [r.id]


def test_current_schema_skips_alembic(db_url, monkeypatch):
    get_engine(db_url)  # creates the schema
    store.dispose_engines()
    calls = []
    monkeypatch.setattr(store_db, "upgrade", lambda engine, revision="head": calls.append(1))
    assert store_db.schema_is_current(get_engine(db_url))
    assert calls == []


def test_listing_a_current_database_does_not_import_alembic(db_url):
    """Start-up cost: a process that only reads a migrated store never loads Alembic."""
    get_engine(db_url)
    code = ("import sys; from inkmotion.store import list_jobs; "
            f"assert list_jobs(limit=5, db_url={db_url!r}) == []; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'alembic'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_record_lifecycle(db_url):
    spec = {"kind": "fit", "input": "text:hi", "params": {"steps": 5}}
    r = store.create_job(spec, kind="fit", queue="optimise", label="text:hi", total=5,
                         db_url=db_url)
    assert (r.status, r.attempts, r.step, r.total, r.spec) == ("queued", 0, 0, 5, spec)
    assert len(r.id) == 32 and r.created_at.tzinfo is not None
    assert store.mark_running(r.id, "w1@a", db_url, owner="w1", lease_s=0.3)
    assert store.update_progress(r.id, 3, 5, {"mse": 0.5, "total": 1.0}, 2.0, db_url)
    mid = store.get_job(r.id, db_url)
    assert (mid.status, mid.step, mid.losses, mid.t_end, mid.worker_host, mid.attempts) == (
        "running", 3, {"mse": 0.5, "total": 1.0}, 2.0, "w1@a", 1)
    # a redelivery while the first attempt's lease is alive is refused; once it expired
    # (its worker died) a second attempt takes the job over
    assert not store.mark_running(r.id, "w2@b", db_url, owner="w2")
    time.sleep(0.4)
    assert store.mark_running(r.id, "w2@b", db_url, owner="w2")
    assert not store.mark_succeeded(r.id, "/elsewhere", db_url, owner="w1")  # not w1's
    assert store.mark_succeeded(r.id, "/data/jobs/x/artifacts", db_url, owner="w2")
    done = store.get_job(r.id, db_url)
    assert (done.status, done.attempts, done.worker_host) == ("succeeded", 2, "w2@b")
    assert done.lease_owner is None and done.lease_until is None
    assert done.finished and done.finished_at >= done.started_at >= done.created_at
    assert done.artifact_dir == "/data/jobs/x/artifacts" and done.metrics is None
    assert json.loads(json.dumps(done.to_dict()))["metrics"] is None
    # a finished job can be neither restarted nor cancelled
    assert not store.mark_running(r.id, "w3@c", db_url)
    assert not store.mark_cancelled(r.id, db_url)
    assert not store.mark_failed(r.id, "late", db_url)


def test_leases_are_renewed_by_their_owner_and_reaped_once(db_url):
    r = store.create_job({}, kind="fit", queue="optimise", db_url=db_url)
    assert store.mark_running(r.id, "w1", db_url, owner="a", lease_s=1.5)
    assert store.renew_lease(r.id, "a", db_url, lease_s=1.5)
    assert not store.renew_lease(r.id, "b", db_url)  # not b's lease
    assert store.update_progress(r.id, 1, 5, db_url=db_url, owner="a", lease_s=1.5)
    assert not store.update_progress(r.id, 2, 5, db_url=db_url, owner="b")
    assert not store.get_job(r.id, db_url).stalled
    assert store.requeue_expired(db_url) == []  # alive: nothing to reap
    time.sleep(1.7)
    assert store.get_job(r.id, db_url).stalled
    reaped = store.requeue_expired(db_url)
    assert [j.id for j in reaped] == [r.id] and reaped[0].status == "queued"
    assert store.requeue_expired(db_url) == []  # re-queued once
    assert not store.renew_lease(r.id, "a", db_url)  # the dead attempt's lease is gone
    assert store.mark_running(r.id, "w2", db_url, owner="c")
    assert store.get_job(r.id, db_url).attempts == 2


def test_concurrent_reapers_requeue_a_job_once(db_url):
    """Eight threads sweep at once: the expired job is re-queued by exactly one."""
    import threading

    r = store.create_job({}, kind="fit", queue="optimise", db_url=db_url)
    assert store.mark_running(r.id, "w1", db_url, owner="a", lease_s=0.01)
    time.sleep(0.05)
    won: list[str] = []
    barrier = threading.Barrier(8)

    def sweep() -> None:
        barrier.wait()
        won.extend(j.id for j in store.requeue_expired(db_url))

    threads = [threading.Thread(target=sweep) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert won == [r.id]


def test_succeeded_job_keeps_its_metrics(db_url):
    np = pytest.importorskip("numpy")
    r = store.create_job({}, kind="evaluate", queue="optimise", db_url=db_url)
    assert store.mark_running(r.id, "w1", db_url)
    metrics = {"chamfer_mean_px": np.float32(0.125), "t_end_ratio": 0.14,
               "per_stroke": np.array([1.0, 2.0]), "diverged": float("nan"), "n": np.int64(3)}
    assert store.mark_succeeded(r.id, "/data/jobs/y/artifacts", db_url, metrics=metrics)
    done = store.get_job(r.id, db_url)
    assert done.metrics == {"chamfer_mean_px": 0.125, "t_end_ratio": 0.14,
                            "per_stroke": [1.0, 2.0], "diverged": None, "n": 3}
    assert json.loads(json.dumps(done.to_dict(), allow_nan=False))["metrics"] == done.metrics
    assert store.list_jobs(db_url=db_url)[0].metrics == done.metrics
    b = store.create_job({}, kind="fit", queue="optimise", db_url=db_url)
    assert store.mark_running(b.id, "w1", db_url)
    with pytest.raises(TypeError, match="not JSON data"):
        store.mark_succeeded(b.id, "/x", db_url, {"bad": object()})
    assert store.get_job(b.id, db_url).status == "running"  # nothing was written


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
        assert store.mark_running(job_id, f"host-{k}", db_url, lease_s=-3600.0)  # no live lease
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


def test_a_cancel_the_heartbeat_sees_first_stops_the_run_as_a_cancel(db_url):
    """A cancel also fails the heartbeat's renewal (the job is no longer running): when the
    heartbeat notices first, the progress observer still stops the run as cancelled, and
    a job another worker took over still as a lost lease."""
    import threading

    from inkmotion.events import StepState
    from inkmotion.workers.leases import LeaseLost
    from inkmotion.workers.progress import JobCancelled, StoreProgressObserver

    step = StepState(1, 5, {}, None)
    cancelled = store.create_job({}, kind="fit", queue="optimise", db_url=db_url)
    assert store.mark_running(cancelled.id, "w1", db_url, owner="a")
    assert store.mark_cancelled(cancelled.id, db_url)
    lost = threading.Event()
    assert not store.renew_lease(cancelled.id, "a", db_url)  # what the heartbeat finds
    lost.set()
    with pytest.raises(JobCancelled):
        StoreProgressObserver(cancelled.id, db_url, owner="a", lost=lost).on_step(step)

    taken = store.create_job({}, kind="fit", queue="optimise", db_url=db_url)
    assert store.mark_running(taken.id, "w1", db_url, owner="a", lease_s=0.01)
    time.sleep(0.05)
    assert [j.id for j in store.requeue_expired(db_url)] == [taken.id]
    assert store.mark_running(taken.id, "w2", db_url, owner="b")
    with pytest.raises(LeaseLost):
        StoreProgressObserver(taken.id, db_url, owner="a", lost=lost).on_step(step)


@pytest.mark.parametrize("url, words", [
    ("foo://bar", "INKMOTION_DB_URL=foo://bar is not a job store this can open"),
    ("sqlite:////proc/inkmotion-none/jobs.db", "its folder cannot be made"),
    ("postgresql+psycopg://user:hidden@127.0.0.1:1/jobs",
     "INKMOTION_DB_URL=postgresql+psycopg://user:***@127.0.0.1:1/jobs cannot be used"),
])
def test_a_job_store_that_cannot_be_used_is_one_sentence(url: str, words: str) -> None:
    """A mistyped or unreachable INKMOTION_DB_URL was a 150-line traceback on the command
    line; now one sentence naming it, its password hidden."""
    if url.startswith("postgresql"):
        pytest.importorskip("psycopg")
    env = {**os.environ, "INKMOTION_DB_URL": url}
    res = subprocess.run([sys.executable, "-m", "inkmotion", "jobs", "list"], env=env,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 1 and words in res.stderr, res.stderr
    assert "Traceback" not in res.stderr and "hidden" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
