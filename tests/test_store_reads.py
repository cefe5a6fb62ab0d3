"""The store's light read path (:mod:`inkmotion.store.reads`) answers exactly as the
SQLAlchemy repository does, and without importing SQLAlchemy."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from inkmotion import store
from inkmotion.errors import SpecError
from inkmotion.store import reads, repository


@pytest.fixture
def db_url(tmp_path: Path) -> str:
    """A SQLite store holding a job in each state (queued, running, succeeded with
    metrics, failed with an error, cancelled) and an id prefix that two jobs share."""
    url = f"sqlite:///{tmp_path / 'jobs.sqlite3'}"
    made = [store.create_job({"kind": "fit", "inputs": {"drawing": f"text:w{i}"}},
                             kind="fit", queue="optimise", label=f"text:w{i}", total=10,
                             job_id=f"abcd{i}{0:027d}", db_url=url) for i in range(5)]
    ids = [r.id for r in made]
    store.mark_running(ids[1], "w1@host", url, owner="w1")
    store.update_progress(ids[1], 4, 10, {"mse": 0.25, "total": 1.5}, 2.5, url)
    store.mark_running(ids[2], "w1@host", url)
    store.mark_succeeded(ids[2], "/data/jobs/x/artifacts", url, metrics={"chamfer": 0.5})
    store.mark_failed(ids[3], "bad input: one sentence.", url)
    store.mark_cancelled(ids[4], url)
    store.dispose_engines()
    return url


def test_reads_match_the_repository(db_url: str) -> None:
    every = repository.list_jobs(limit=None, db_url=db_url)
    assert len(every) == 5
    assert reads.list_jobs(limit=None, db_url=db_url) == every
    assert reads.list_jobs(limit=2, db_url=db_url) == every[:2]
    for status in ("running", ["succeeded", "failed"]):
        assert (reads.list_jobs(status, db_url=db_url)
                == repository.list_jobs(status, db_url=db_url) != [])
    for record in every:
        assert reads.get_job(record.id, db_url) == record
        assert reads.find_job(record.id[:5], db_url) == record
    one = reads.get_job(every[0].id, db_url)
    assert one is not None and one.created_at.tzinfo is not None
    ambiguous = reads.find_job("abcd", db_url)
    assert isinstance(ambiguous, list) and len(ambiguous) == 5
    assert ambiguous == repository.find_job("abcd", db_url)
    assert reads.get_job("nope", db_url) is None and reads.find_job("abc_", db_url) is None
    with pytest.raises(SpecError, match="Unknown status done"):
        reads.list_jobs("done", db_url=db_url)


def test_a_new_store_goes_through_the_repository(tmp_path: Path) -> None:
    """A file that does not exist yet is created and migrated, as before."""
    url = f"sqlite:///{tmp_path / 'new' / 'jobs.sqlite3'}"
    assert reads.list_jobs(db_url=url) == []
    assert (tmp_path / "new" / "jobs.sqlite3").is_file()
    assert reads.sqlite_file("postgresql://u@h/db") is None
    assert reads.sqlite_file("sqlite://") is None
    assert reads.sqlite_file("sqlite:////tmp/x.db?timeout=3") is None
    assert reads.sqlite_file("sqlite:////tmp/x.db") == Path("/tmp/x.db")


def test_reading_a_current_store_imports_no_sqlalchemy(db_url: str) -> None:
    code = ("import sys; from inkmotion.store import find_job, list_jobs; "
            f"assert len(list_jobs(db_url={db_url!r})) == 5; "
            f"assert len(find_job('abcd', {db_url!r})) == 5; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'sqlalchemy', 'alembic'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"
