"""Fixtures that start the real services: a redis-server on a free loopback port, a job
store in a temporary SQLite file, and Celery worker subprocesses (solo pool).

Include them from ``tests/conftest.py`` with ``pytest_plugins = ["service_fixtures"]``
(or ``from service_fixtures import *``). Tests using them are marked
``@pytest.mark.services`` and are skipped when ``redis-server`` is not installed. The
processes themselves are started by :mod:`inkmotion.workers.local`, which the
``inkmotion bench --only queue`` benchmark shares.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from inkmotion.workers.local import (
    WORKER_READY_TIMEOUT,  # noqa: F401  (re-exported for tests)
    WorkerPool,
    free_port,  # noqa: F401  (re-exported for tests)
    redis_binary,
    start_redis,
)

#: Redis redelivers a job whose worker died after this many seconds (tests only: jobs here
#: are far shorter, so a healthy job is never delivered twice)
TEST_VISIBILITY_TIMEOUT = 20


@pytest.fixture(scope="session")
def redis_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A real redis-server on a free loopback port, no persistence; its URL."""
    if redis_binary() is None:
        pytest.skip("redis-server is not installed (apt-get install redis-server)")
    server = start_redis(tmp_path_factory.mktemp("redis"))
    try:
        yield server.url
    finally:
        server.stop()


@pytest.fixture(scope="session")
def service_env(redis_url: str,
                tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, str]]:
    """INKMOTION_* variables for a temporary data dir, SQLite store and the test Redis,
    set in this process for the session (workers and CLI subprocesses inherit them)."""
    data = tmp_path_factory.mktemp("inkmotion-data")
    env = {
        "INKMOTION_DATA_DIR": str(data),
        "INKMOTION_DB_URL": f"sqlite:///{data / 'jobs.sqlite3'}",
        "INKMOTION_BROKER_URL": redis_url,
        "INKMOTION_VISIBILITY_TIMEOUT": str(TEST_VISIBILITY_TIMEOUT),
        "INKMOTION_RESTORE_INTERVAL": "1",
        # a killed worker's job is queued again by a reaper within seconds
        "INKMOTION_LEASE_S": "8",
        "INKMOTION_REAPER_INTERVAL": "1",
        "INKMOTION_SOFT_TIME_LIMIT": str(TEST_VISIBILITY_TIMEOUT - 5),
        "INKMOTION_TIME_LIMIT": str(TEST_VISIBILITY_TIMEOUT - 2),
    }
    with pytest.MonkeyPatch.context() as mp:
        for k, v in env.items():
            mp.setenv(k, v)
        yield env
    from inkmotion.store import dispose_engines

    dispose_engines()


@pytest.fixture(scope="session")
def worker_pool(service_env: dict[str, str],
                tmp_path_factory: pytest.TempPathFactory) -> Iterator[WorkerPool]:
    """The session's worker pool (started lazily; stopped at the end)."""
    pool = WorkerPool(service_env, tmp_path_factory.mktemp("workers"))
    try:
        yield pool
    finally:
        pool.stop_all()


@pytest.fixture
def workers(worker_pool: WorkerPool) -> WorkerPool:
    """Two running workers, w1 and w2 (restarted when a test killed one)."""
    return worker_pool.ensure()


def inkmotion_cli(*args: str, env: dict[str, str] | None = None,
                  timeout: float = 120) -> subprocess.CompletedProcess:
    """Run the real ``inkmotion`` command line in a subprocess; captures its output."""
    script = Path(sys.executable).with_name("inkmotion")
    cmd = [str(script)] if script.is_file() else [
        sys.executable, "-c", "from inkmotion.cli.main import main; main()"]
    return subprocess.run([*cmd, *args], env={**os.environ, **(env or {})}, text=True,
                          capture_output=True, timeout=timeout)


def wait_for(predicate: object, timeout: float, interval: float = 0.2) -> object:
    """Poll ``predicate()`` until it returns something truthy; that value, or fail."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()  # type: ignore[operator]
        if value:
            return value
        time.sleep(interval)
    pytest.fail(f"condition not met within {timeout} s")
