"""Resolved settings of the distributed path: data directory, job store, broker, limits.

Everything is read from the environment when :func:`load_settings` is called (never at
import), so a test or a worker can point the same code at another data directory, database
or broker by setting variables first:

=============================  ========================================================
INKMOTION_DATA_DIR             artifacts and input copies (default: the user data dir)
INKMOTION_DB_URL               SQLAlchemy URL (default: SQLite file ``jobs.sqlite3`` there)
INKMOTION_BROKER_URL           Redis URL, ``redis://`` or ``rediss://`` (TLS)
INKMOTION_MAX_INPUT_MB         largest input file accepted by ``submit`` (default 50)
INKMOTION_SOFT_TIME_LIMIT      seconds before a job is asked to stop (default 3 h)
INKMOTION_TIME_LIMIT           seconds before a job is killed (default soft + 5 min)
INKMOTION_VISIBILITY_TIMEOUT   seconds before Redis redelivers an unacknowledged job
                               (default time limit + 10 min: must exceed the longest job)
INKMOTION_RESTORE_INTERVAL     seconds between Redis's sweeps for unacknowledged jobs
                               past the visibility timeout (default 60)
INKMOTION_LEASE_S              seconds a running job's lease lasts without a heartbeat
                               (default 30; heartbeats every third of it)
INKMOTION_REAPER_INTERVAL      seconds between a worker's looks for expired leases,
                               whose jobs it puts back on their queue (default 10): a
                               dead worker's job runs again within lease + interval
INKMOTION_STRANDED_S           seconds a worker with nothing to do waits before it sends
                               again the jobs of its queues that stayed queued all that
                               time (their message lost: Redis emptied, a worker with
                               another job store took it) (default 120)
INKMOTION_CHECKPOINT_STEPS     a running job's checkpoint every this many steps (50) ...
INKMOTION_CHECKPOINT_S         ... or seconds (30), whichever comes first; a redelivered
                               job resumes from its last checkpoint
=============================  ========================================================
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from inkmotion.errors import SpecError

DEFAULT_BROKER_URL = "redis://127.0.0.1:6379/0"


def user_data_dir() -> Path:
    """The per-user data directory (``platformdirs`` when installed)."""
    try:
        import platformdirs
    except ImportError:
        base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
        return Path(base) / "inkmotion"
    return Path(platformdirs.user_data_dir("inkmotion", appauthor=False))


@dataclass(frozen=True)
class Settings:
    """One consistent snapshot of the settings (see the module docstring)."""

    data_dir: Path
    db_url: str
    broker_url: str
    max_input_bytes: int
    soft_time_limit: int  # s
    time_limit: int  # s, hard
    visibility_timeout: int  # s, > time_limit
    restore_interval: int  # s
    lease_s: float = 30.0  # s a running attempt's lease lasts without a heartbeat
    reaper_interval: float = 10.0  # s between two looks for expired leases
    stranded_s: float = 120.0  # s an idle worker waits before re-sending stranded jobs
    checkpoint_steps: int = 50  # a running job's checkpoint every this many steps ...
    checkpoint_s: float = 30.0  # ... or seconds, whichever comes first

    @property
    def jobs_dir(self) -> Path:
        """``<data_dir>/jobs``: one folder per job (input/, artifacts/, job.log)."""
        return self.data_dir / "jobs"

    def job_dir(self, job_id: str) -> Path:
        return self.jobs_dir / job_id


def _number(name: str, default: float) -> float:
    raw = os.environ.get(name)
    if raw is None or raw.strip() == "":
        return default
    try:
        value = float(raw)
    except ValueError as exc:
        raise SpecError(f"{name}={raw!r} must be a number.") from exc
    if value <= 0:
        raise SpecError(f"{name}={raw!r} must be positive.")
    return value


def load_settings() -> Settings:
    """Read the environment now and return the resolved :class:`Settings`."""
    data_dir = Path(os.environ.get("INKMOTION_DATA_DIR") or user_data_dir()).expanduser()
    db_url = os.environ.get("INKMOTION_DB_URL") or f"sqlite:///{data_dir / 'jobs.sqlite3'}"
    broker_url = os.environ.get("INKMOTION_BROKER_URL") or DEFAULT_BROKER_URL
    soft = int(_number("INKMOTION_SOFT_TIME_LIMIT", 3 * 3600))
    hard = int(_number("INKMOTION_TIME_LIMIT", soft + 300))
    if hard < soft:
        raise SpecError(f"INKMOTION_TIME_LIMIT={hard} must not be below "
                        f"INKMOTION_SOFT_TIME_LIMIT={soft}.")
    visibility = int(_number("INKMOTION_VISIBILITY_TIMEOUT", hard + 600))
    return Settings(
        data_dir=data_dir,
        db_url=db_url,
        broker_url=broker_url,
        max_input_bytes=int(_number("INKMOTION_MAX_INPUT_MB", 50) * 1024 * 1024),
        soft_time_limit=soft,
        time_limit=hard,
        visibility_timeout=visibility,
        restore_interval=int(_number("INKMOTION_RESTORE_INTERVAL", 60)),
        lease_s=float(_number("INKMOTION_LEASE_S", 30)),
        reaper_interval=float(_number("INKMOTION_REAPER_INTERVAL", 10)),
        stranded_s=float(_number("INKMOTION_STRANDED_S", 120)),
        checkpoint_steps=int(_number("INKMOTION_CHECKPOINT_STEPS", 50)),
        checkpoint_s=float(_number("INKMOTION_CHECKPOINT_S", 30)),
    )


def redact_url(url: str) -> str:
    """``url`` with any password replaced by ``***`` (safe to print in messages)."""
    from urllib.parse import urlsplit, urlunsplit

    parts = urlsplit(url)
    if parts.password is None:
        return url
    netloc = parts.netloc.rsplit("@", 1)
    user = parts.username or ""
    return urlunsplit(parts._replace(netloc=f"{user}:***@{netloc[-1]}"))
