"""Local services: a throwaway redis-server and Celery worker subprocesses on this machine,
for benchmarks, tests and trying things out.

Nothing here is meant for production (use ``inkmotion worker`` and a managed Redis there):
the Redis started by :func:`start_redis` listens on loopback only, keeps nothing on disk,
and every subprocess runs in its own process group so that :func:`stop_process` can end it
with all its children. Example::

    with start_redis(Path(tmp) / "redis") as redis:
        pool = WorkerPool({"INKMOTION_BROKER_URL": redis.url, ...}, Path(tmp) / "logs")
        try:
            pool.ensure(("w1", "w2"))
            ...  # submit jobs, wait for them
        finally:
            pool.stop_all()
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

from inkmotion.errors import ServiceError

#: seconds a worker subprocess may take to print " ready." (it imports torch first)
WORKER_READY_TIMEOUT = 90.0
#: the loopback address every local service binds to
HOST = "127.0.0.1"


def free_port() -> int:
    """A TCP port on loopback that is free now (the OS picks it)."""
    with socket.socket() as s:
        s.bind((HOST, 0))
        return int(s.getsockname()[1])


def wait_for_redis(port: int, timeout: float, host: str = HOST) -> bool:
    """Poll ``host:port`` until a Redis answers ``PING`` with ``+PONG``; ``False`` when
    none did within ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with socket.create_connection((host, port), timeout=0.2) as s:
                s.sendall(b"PING\r\n")
                if s.recv(16).startswith(b"+PONG"):
                    return True
        except OSError:
            pass
        time.sleep(0.05)
    return False


def stop_process(proc: subprocess.Popen[bytes], grace: float = 10.0,
                 first: int = signal.SIGTERM) -> None:
    """Signal ``first`` (SIGTERM; SIGINT is a terminal's Ctrl-C) to the process group of
    ``proc`` (started with ``start_new_session=True``), then SIGKILL what is left after
    ``grace`` seconds. No-op when it has exited."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, first)
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


def redis_binary() -> str | None:
    """The path of ``redis-server`` on PATH, or ``None`` when it is not installed."""
    return shutil.which("redis-server")


@dataclass
class RedisServer:
    """A running redis-server subprocess (see :func:`start_redis`); a context manager
    that stops it on exit."""

    proc: subprocess.Popen[bytes]
    port: int
    folder: Path

    @property
    def url(self) -> str:
        """The broker URL, database 0."""
        return f"redis://{HOST}:{self.port}/0"

    @property
    def log(self) -> Path:
        """The server's log file."""
        return self.folder / "redis.log"

    def stop(self, grace: float = 5.0) -> None:
        """Stop the server (SIGTERM, then SIGKILL after ``grace`` seconds)."""
        stop_process(self.proc, grace=grace)

    def __enter__(self) -> RedisServer:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()


def start_redis(folder: Path, port: int | None = None, timeout: float = 10.0,
                binary: str | None = None, aof: bool = False) -> RedisServer:
    """Start a redis-server on loopback (a free port unless ``port``), without
    persistence (with ``aof``: an append-only file, fsync every second, as the deploy
    guide runs it, so a restart in the same ``folder`` keeps the queue), working in
    ``folder`` (created; it holds ``redis.log``); returns once it answers ``PING``.

    Raises :class:`~inkmotion.errors.ServiceError` (one sentence) when ``redis-server``
    is not installed or does not come up within ``timeout`` seconds.
    """
    binary = binary or redis_binary()
    if binary is None:
        raise ServiceError("redis-server is not installed; install it with "
                           "`apt-get install redis-server` (or put it on PATH).")
    port = port or free_port()
    folder.mkdir(parents=True, exist_ok=True)
    server_log = folder / "redis.log"
    with open(server_log, "wb") as log:
        proc = subprocess.Popen(
            [binary, "--port", str(port), "--bind", HOST, "--save", "",
             "--appendonly", "yes" if aof else "no", "--appendfsync", "everysec",
             "--maxmemory-policy", "noeviction", "--daemonize", "no", "--dir", str(folder)],
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    server = RedisServer(proc, port, folder)
    if not wait_for_redis(port, timeout):
        server.stop()
        raise ServiceError(f"redis-server did not start on port {port} within {timeout:g} s; "
                           f"see {server_log}.")
    return server


@dataclass
class WorkerPool:
    """Real Celery worker subprocesses (``--pool=solo``, one job at a time, every queue the
    job kinds declare unless ``queues`` is given), one per node name, each logging to
    ``logs/<name>.log``.

    ``env`` (e.g. the ``INKMOTION_*`` variables) is added to this process's environment
    for every worker; each job runs with its spec's thread count (default 1), so workers
    on one machine do not fight over its cores.
    """

    env: dict[str, str]
    logs: Path
    procs: dict[str, subprocess.Popen[bytes]] = field(default_factory=dict)
    queues: tuple[str, ...] = ()
    #: job slots per worker: > 1 runs a prefork pool of that many children (each job runs
    #: with the thread count of its spec, default 1: :mod:`inkmotion.devices`)
    concurrency: int = 1
    #: a prefork pool even of one child, as ``inkmotion worker`` runs by default (the job
    #: in a child process, which the main process ends when it loses the broker)
    prefork: bool = False

    def __post_init__(self) -> None:
        if not self.queues:
            from inkmotion.workers.app import known_queues

            self.queues = known_queues()

    def command(self, name: str) -> list[str]:
        """The command line of worker ``name``."""
        pool = "prefork" if self.prefork or self.concurrency > 1 else "solo"
        return [sys.executable, "-m", "celery", "-A", "inkmotion.workers.app", "worker",
                f"--pool={pool}", f"--concurrency={self.concurrency}",
                f"--queues={','.join(self.queues)}",
                "--without-heartbeat", "--without-gossip", "--without-mingle",
                f"--hostname={name}@%h", "--loglevel=info"]

    def log_path(self, name: str) -> Path:
        """The log file of worker ``name``."""
        return self.logs / f"{name}.log"

    def start(self, name: str) -> None:
        """Start worker ``name`` (no-op when it runs); returns once it is ready.

        Raises ``RuntimeError`` when it exits or is not ready within
        :data:`WORKER_READY_TIMEOUT` seconds (it is left in :attr:`procs` to be stopped).
        """
        proc = self.procs.get(name)
        if proc is not None and proc.poll() is None:
            return
        self.logs.mkdir(parents=True, exist_ok=True)
        log = self.log_path(name)
        offset = log.stat().st_size if log.exists() else 0
        env = {**os.environ, **self.env, "PYTHONUNBUFFERED": "1"}
        with open(log, "ab") as fh:
            self.procs[name] = proc = subprocess.Popen(
                self.command(name), env=env, stdout=fh, stderr=subprocess.STDOUT,
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
        """Start the named workers that are not running; returns ``self``."""
        for name in names:
            self.start(name)
        return self

    def kill(self, name: str) -> None:
        """``kill -9`` the worker's whole process group, as a crashed machine would."""
        proc = self.procs.pop(name)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)

    def stop_all(self) -> None:
        """Stop every worker: SIGTERM (Celery's warm shutdown), SIGKILL after 10 s."""
        for name in list(self.procs):
            stop_process(self.procs.pop(name))


def postgres_bin_dir() -> Path | None:
    """The folder of the PostgreSQL server programs (Debian's newest
    /usr/lib/postgresql/N/bin, else ``postgres`` on PATH), or None when not installed."""
    debian = sorted(Path("/usr/lib/postgresql").glob("*/bin/postgres"),
                    key=lambda p: int(p.parent.parent.name) if p.parent.parent.name.isdigit()
                    else 0)
    if debian:
        return debian[-1].parent
    found = shutil.which("postgres")
    return Path(found).parent if found else None


@dataclass
class PostgresServer:
    """A throw-away PostgreSQL server (see :func:`start_postgres`)."""

    proc: subprocess.Popen[bytes]
    port: int
    folder: Path
    bin_dir: Path

    def url(self, database: str = "inkmotion") -> str:
        """The SQLAlchemy URL of ``database`` (psycopg 3 driver)."""
        return f"postgresql+psycopg://inkmotion@{HOST}:{self.port}/{database}"

    def create_database(self, name: str) -> str:
        """Create the database ``name``; returns its URL."""
        import psycopg

        with psycopg.connect(f"host={HOST} port={self.port} user=inkmotion dbname=postgres",
                             autocommit=True) as conn:
            conn.execute(f'CREATE DATABASE "{name}"')
        return self.url(name)

    def halt(self, grace: float = 10.0) -> None:
        """Stop the server (its data stays: :meth:`resume` starts it again)."""
        stop_process(self.proc, grace=grace)

    def resume(self, timeout: float = 30.0) -> None:
        """Start the halted server again on the same port and data."""
        self.proc = _launch_postgres(self.bin_dir, self.folder, self.port)
        _wait_postgres(self, timeout)

    def stop(self, grace: float = 10.0) -> None:
        """Stop the server and remove its folder."""
        stop_process(self.proc, grace=grace)
        shutil.rmtree(self.folder, ignore_errors=True)


def _as_postgres_user(cmd: list[str]) -> list[str]:
    """``cmd`` run as the ``postgres`` user when we are root (PostgreSQL refuses root)."""
    if os.geteuid() != 0:
        return cmd
    return ["runuser", "-u", "postgres", "--", *cmd]


def _launch_postgres(bin_dir: Path, folder: Path, port: int) -> subprocess.Popen[bytes]:
    with open(folder / "postgres.log", "ab") as log:
        return subprocess.Popen(_as_postgres_user([
            str(bin_dir / "postgres"), "-D", str(folder / "data"), "-p", str(port), "-k",
            str(folder), "-c", f"listen_addresses={HOST}", "-c", "fsync=off", "-c",
            "full_page_writes=off"]), stdout=log, stderr=subprocess.STDOUT,
            start_new_session=True)


def _wait_postgres(server: PostgresServer, timeout: float) -> None:
    import psycopg

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and server.proc.poll() is None:
        try:
            psycopg.connect(f"host={HOST} port={server.port} user=inkmotion dbname=postgres",
                            connect_timeout=2).close()
            return
        except psycopg.OperationalError:
            time.sleep(0.2)
    raise ServiceError(f"PostgreSQL did not start on port {server.port} within {timeout:g} s;"
                       f" see {server.folder / 'postgres.log'}.")


def start_postgres(port: int | None = None, timeout: float = 30.0) -> PostgresServer:
    """Initialise and start a PostgreSQL server on loopback (a free port unless ``port``)
    in a new temporary folder, trust authentication for the user ``inkmotion``, fsync off
    (a test server); returns once it accepts connections. Raises
    :class:`~inkmotion.errors.ServiceError` when PostgreSQL is not installed or does not
    come up."""
    import tempfile

    bin_dir = postgres_bin_dir()
    if bin_dir is None:
        raise ServiceError("PostgreSQL is not installed; install it with "
                           "`apt-get install postgresql`.")
    folder = Path(tempfile.mkdtemp(prefix="inkmotion-pg-"))
    folder.chmod(0o755)
    if os.geteuid() == 0:
        shutil.chown(folder, "postgres", "postgres")
    init = subprocess.run(_as_postgres_user([str(bin_dir / "initdb"), "-D",
                                             str(folder / "data"), "-A", "trust", "-U",
                                             "inkmotion", "-E", "UTF8", "--no-sync"]),
                          capture_output=True, text=True)
    if init.returncode != 0:
        shutil.rmtree(folder, ignore_errors=True)
        raise ServiceError(f"initdb failed: {init.stderr.strip().splitlines()[-1:]}")
    port = port or free_port()
    server = PostgresServer(_launch_postgres(bin_dir, folder, port), port, folder, bin_dir)
    try:
        _wait_postgres(server, timeout)
    except ServiceError:
        server.stop()
        raise
    return server
