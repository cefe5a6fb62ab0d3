"""Broker and database faults with real services: Redis killed with SIGKILL and restarted
with its append-only file while jobs are queued and running; PostgreSQL stopped and
started again under a running job; and the whole job path on a PostgreSQL store."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from inkmotion import store
from inkmotion.workers.local import (
    WorkerPool,
    postgres_bin_dir,
    redis_binary,
    start_postgres,
    start_redis,
)

pytestmark = [pytest.mark.services,
              pytest.mark.skipif(redis_binary() is None, reason="redis-server is not installed")]

#: production-like limits (leases decide redelivery, not the visibility timeout)
LIMITS = {"INKMOTION_SOFT_TIME_LIMIT": "10800", "INKMOTION_TIME_LIMIT": "11100",
          "INKMOTION_VISIBILITY_TIMEOUT": "11700"}


def submit(env: dict[str, str], *args: str) -> list[str]:
    cli = Path(sys.executable).with_name("inkmotion")
    res = subprocess.run([str(cli), "submit", "fit", *args], capture_output=True, text=True,
                         env={**os.environ, **env}, timeout=120)
    assert res.returncode == 0, res.stderr
    return res.stdout.split()


def wait_all(ids: list[str], db: str, timeout: float) -> list[store.JobRecord]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        records = [store.get_job(i, db) for i in ids]
        if all(r is not None and r.finished for r in records):
            return records
        time.sleep(0.5)
    raise AssertionError(f"not finished in {timeout} s: "
                         f"{[(r.id[:8], r.status) for r in records]}")


def one_result_set(data: Path, job_id: str) -> bool:
    folder = data / "jobs" / job_id
    return ([p.name for p in folder.glob("artifacts*")] == ["artifacts"]
            and (folder / "artifacts" / "report.json").is_file())


def redis_away(services: dict, seconds: float) -> None:
    """Redis killed with SIGKILL (its append-only file synced first) and started again on
    its port ``seconds`` later."""
    time.sleep(1.5)  # the append-only file is synced every second
    redis = services["redis"]
    os.kill(redis.proc.pid, 9)
    redis.proc.wait(10)
    time.sleep(seconds)
    services["redis"] = start_redis(redis.folder, port=redis.port, aof=True)


@pytest.fixture
def services(tmp_path: Path) -> Iterator[dict]:
    """A Redis with AOF, a SQLite store and an empty worker pool in ``tmp_path``."""
    redis = start_redis(tmp_path / "redis", aof=True)
    data = tmp_path / "data"
    env = {"INKMOTION_DATA_DIR": str(data), "INKMOTION_BROKER_URL": redis.url,
           "INKMOTION_DB_URL": f"sqlite:///{data / 'jobs.sqlite3'}", **LIMITS}
    pool = WorkerPool(env, tmp_path / "logs")
    state = {"redis": redis, "env": env, "pool": pool, "data": data, "tmp": tmp_path}
    try:
        yield state
    finally:
        pool.stop_all()
        state["redis"].stop()
        store.dispose_engines()


def test_redis_killed_and_restarted_with_aof_loses_no_job(services: dict) -> None:
    env, pool, data = services["env"], services["pool"], services["data"]
    pool.ensure(("r1", "r2"))
    ids = [i for w in ("hi", "ok", "hello", "ink", "tag", "sky")
           for i in submit(env, f"text:{w}", "--steps", "150", "--size", "96")]
    db = env["INKMOTION_DB_URL"]
    deadline = time.monotonic() + 60
    while not any(store.get_job(i, db).status == "running" for i in ids):
        assert time.monotonic() < deadline, "no job started"
        time.sleep(0.2)
    redis_away(services, 3)  # jobs keep running; workers lose the broker
    records = wait_all(ids, db, timeout=240)
    assert [r.status for r in records] == ["succeeded"] * len(ids)
    assert all(one_result_set(data, i) for i in ids)
    assert all(pool.procs[n].poll() is None for n in ("r1", "r2"))  # reconnected, alive
    print({r.id[:8]: r.attempts for r in records})


def test_redis_down_longer_than_a_lease_strands_no_job(services: dict) -> None:
    """Redis away for longer than a lease: Celery ends the running task (its message
    cannot be acknowledged), the lease expires, and the reapers cannot send the job again
    while the broker is down. The job is put back as they found it, and sent once Redis
    is back: it finishes in seconds, not at the broker's redelivery three hours later
    (before, it sat 'queued' with no message)."""
    env = {**services["env"], "INKMOTION_LEASE_S": "4", "INKMOTION_REAPER_INTERVAL": "1"}
    services["env"].update(env)
    pool, data = services["pool"], services["data"]
    pool.prefork = True  # as `inkmotion worker` runs: the job in a child the broker's loss ends
    pool.ensure(("o1",))
    # long enough to be running when the broker goes (1.5 s after its first step), short
    # enough that its second attempt ends well within the wait below on a loaded machine:
    # ~30 s alone on 2 cores (6000 steps took 87 s there once the fit grew its edits)
    (job,) = submit(env, "text:hello", "--steps", "2000", "--size", "96")
    db = env["INKMOTION_DB_URL"]
    deadline = time.monotonic() + 60
    while store.get_job(job, db).status != "running" or not store.get_job(job, db).step:
        assert time.monotonic() < deadline, "the job did not start"
        time.sleep(0.2)
    redis_away(services, 12)  # three leases: expired, the reaper failing to send each look
    (record,) = wait_all([job], db, timeout=240)
    assert record.status == "succeeded" and one_result_set(data, job)
    assert record.attempts >= 2  # the ended attempt, then the one the reaper sent


def test_a_worker_that_cannot_write_the_data_dir_fails_the_job_in_one_sentence(
        services: dict) -> None:
    """A worker whose INKMOTION_DATA_DIR it cannot write (a read-only mount) raised before
    the job's log was open: running, stalled, running again every lease, forever, with no
    error recorded. Now the job fails at once, saying which folder and what to do."""
    pool, env = services["pool"], services["env"]
    pool.env = {**env, "INKMOTION_DATA_DIR": "/proc/inkmotion-none"}
    pool.ensure(("ro",))
    (job,) = submit(env, "text:hi", "--steps", "5", "--size", "64")
    (record,) = wait_all([job], env["INKMOTION_DB_URL"], timeout=60)
    assert record.status == "failed" and record.attempts == 1
    assert "cannot write the job's folder /proc/inkmotion-none/jobs/" in record.error
    assert "give INKMOTION_DATA_DIR a folder every worker can write" in record.error


def test_a_job_whose_message_is_lost_is_sent_again_by_an_idle_worker(services: dict) -> None:
    """Redis emptied under queued jobs (a failover to a lagging replica, a restart without
    its files), or their messages taken and dropped by a worker with another job store:
    the store says they are queued, and nothing would ever send them. A worker idle for
    INKMOTION_STRANDED_S sends them again."""
    import redis as redis_py

    env = {**services["env"], "INKMOTION_STRANDED_S": "3", "INKMOTION_REAPER_INTERVAL": "1"}
    pool = services["pool"]
    pool.env = env
    ids = [i for w in ("lost", "gone") for i in submit(env, f"text:{w}", "--steps", "5",
                                                        "--size", "64")]
    redis_py.Redis.from_url(env["INKMOTION_BROKER_URL"]).flushall()
    pool.ensure(("idle",))
    records = wait_all(ids, env["INKMOTION_DB_URL"], timeout=90)
    assert [r.status for r in records] == ["succeeded"] * 2
    assert all(one_result_set(services["data"], i) for i in ids)
    assert "message lost; sent again" in pool.log_path("idle").read_text()


@pytest.fixture
def postgres_services(services: dict) -> Iterator[dict]:
    if postgres_bin_dir() is None:
        pytest.skip("PostgreSQL is not installed (apt-get install postgresql)")
    pytest.importorskip("psycopg")
    server = start_postgres()
    services["env"]["INKMOTION_DB_URL"] = server.create_database("jobs")
    services["postgres"] = server
    try:
        yield services
    finally:
        services["pool"].stop_all()
        store.dispose_engines()
        server.stop()


def test_jobs_run_exactly_once_on_a_postgresql_store(postgres_services: dict) -> None:
    env, pool, data = (postgres_services[k] for k in ("env", "pool", "data"))
    pool.ensure(("p1", "p2"))
    ids = [i for w in ("hi", "ok", "ink", "sky") for i in submit(env, f"text:{w}", "--steps",
                                                                  "20", "--size", "64")]
    records = wait_all(ids, env["INKMOTION_DB_URL"], timeout=180)
    assert [(r.status, r.attempts) for r in records] == [("succeeded", 1)] * 4
    assert all(one_result_set(data, i) for i in ids)


def test_postgresql_briefly_down_fails_no_job(postgres_services: dict) -> None:
    """The database stops for 8 s under a running job: progress writes and lease renewals
    fail and are retried (and a final write that falls in the outage waits for the
    database); the job is not marked failed and completes in one attempt."""
    env, pool, data = (postgres_services[k] for k in ("env", "pool", "data"))
    server = postgres_services["postgres"]
    db = env["INKMOTION_DB_URL"]
    pool.ensure(("p1",))
    (job_id,) = submit(env, "text:hello", "--steps", "1200", "--size", "128")
    deadline = time.monotonic() + 90
    while (store.get_job(job_id, db).step or 0) < 100:
        assert time.monotonic() < deadline, "the job did not start"
        time.sleep(0.2)
    store.dispose_engines()  # this process's connections go with the server
    server.halt()
    time.sleep(8)
    server.resume()
    (record,) = wait_all([job_id], db, timeout=180)
    assert (record.status, record.attempts, record.step) == ("succeeded", 1, 1200)
    assert one_result_set(data, job_id)
    log = (data / "jobs" / job_id / "job.log").read_text()
    assert any(m in log for m in ("progress not recorded", "lease not renewed",
                                  "job store unreachable")), log
