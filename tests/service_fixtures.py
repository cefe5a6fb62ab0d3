"""Fixtures that start the real services: a redis-server on a free loopback port, a job
store in a temporary SQLite file, and Celery worker subprocesses (solo pool).

Include them from ``tests/conftest.py`` with ``pytest_plugins = ["service_fixtures"]``
(or ``from service_fixtures import *``). Tests using them are marked
``@pytest.mark.services`` and are skipped when ``redis-server`` is not installed.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

#: Redis redelivers a job whose worker died after this many seconds (tests only: jobs here
#: are far shorter, so a healthy job is never delivered twice)
TEST_VISIBILITY_TIMEOUT = 20
WORKER_READY_TIMEOUT = 90.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for_port(port: int, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.2) as s:
                s.sendall(b"PING\r\n")
                if s.recv(16).startswith(b"+PONG"):
                    return True
        except OSError:
            time.sleep(0.05)
    return False


def _stop(proc: subprocess.Popen, grace: float = 10.0) -> None:
    """SIGTERM the process group, then SIGKILL what is left after ``grace`` seconds."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGTERM)
    except ProcessLookupError:
        return
    try:
        proc.wait(grace)
    except subprocess.TimeoutExpired:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait(5)


@pytest.fixture(scope="session")
def redis_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A real redis-server on a free loopback port, no persistence; its URL."""
    binary = shutil.which("redis-server")
    if binary is None:
        pytest.skip("redis-server is not installed (apt-get install redis-server)")
    port = free_port()
    folder = tmp_path_factory.mktemp("redis")
    proc = subprocess.Popen(
        [binary, "--port", str(port), "--bind", "127.0.0.1", "--save", "", "--appendonly",
         "no", "--daemonize", "no", "--dir", str(folder)],
        stdout=open(folder / "redis.log", "wb"), stderr=subprocess.STDOUT,
        start_new_session=True)
    try:
        if not _wait_for_port(port, 10.0):
            raise RuntimeError(f"redis-server did not start; see {folder / 'redis.log'}")
        yield f"redis://127.0.0.1:{port}/0"
    finally:
        _stop(proc, grace=5.0)


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
        "INKMOTION_SOFT_TIME_LIMIT": str(TEST_VISIBILITY_TIMEOUT - 5),
        "INKMOTION_TIME_LIMIT": str(TEST_VISIBILITY_TIMEOUT - 2),
    }
    with pytest.MonkeyPatch.context() as mp:
        for k, v in env.items():
            mp.setenv(k, v)
        yield env
    from inkmotion.store import dispose_engines

    dispose_engines()


@dataclass
class WorkerPool:
    """Real Celery worker subprocesses (``--pool=solo``), one per node name."""

    env: dict[str, str]
    logs: Path
    procs: dict[str, subprocess.Popen] = field(default_factory=dict)

    def command(self, name: str) -> list[str]:
        return [sys.executable, "-m", "celery", "-A", "inkmotion.workers.app", "worker",
                "--pool=solo", "--concurrency=1", "--queues=optimise,simulate",
                "--without-heartbeat", "--without-gossip", "--without-mingle",
                f"--hostname={name}@%h", "--loglevel=info"]

    def log_path(self, name: str) -> Path:
        return self.logs / f"{name}.log"

    def start(self, name: str) -> None:
        """Start worker ``name`` (no-op when it runs); returns once it is ready."""
        proc = self.procs.get(name)
        if proc is not None and proc.poll() is None:
            return
        log = self.log_path(name)
        offset = log.stat().st_size if log.exists() else 0
        env = {**os.environ, **self.env, "OMP_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"}
        self.procs[name] = proc = subprocess.Popen(
            self.command(name), env=env, stdout=open(log, "ab"), stderr=subprocess.STDOUT,
            start_new_session=True)
        deadline = time.monotonic() + WORKER_READY_TIMEOUT
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                raise RuntimeError(f"worker {name} exited; see {log}")
            with open(log, "rb") as fh:
                fh.seek(offset)
                if b" ready." in fh.read():
                    return
            time.sleep(0.1)
        raise RuntimeError(f"worker {name} was not ready in {WORKER_READY_TIMEOUT} s; see {log}")

    def ensure(self, names: tuple[str, ...] = ("w1", "w2")) -> WorkerPool:
        for name in names:
            self.start(name)
        return self

    def kill(self, name: str) -> None:
        """``kill -9`` the worker's whole process group, as a crashed machine would."""
        proc = self.procs.pop(name)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)

    def stop_all(self) -> None:
        for name in list(self.procs):
            _stop(self.procs.pop(name))


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
