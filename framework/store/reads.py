"""The job store's read-only queries (one job, a prefix, a listing), fast to start.

``inkmotion jobs list``, ``jobs show``, ``jobs wait`` and ``view`` only read the store, and
importing SQLAlchemy costs more than the rest of such a command. So on a SQLite store that
already exists at :data:`~inkmotion.store.migrations.HEAD_REVISION` these functions read
it with the standard library's ``sqlite3`` and build the same :class:`JobRecord` that
:mod:`inkmotion.store.repository` builds (``tests/test_store_reads.py`` compares them);
any other store (PostgreSQL, a new or older SQLite file: it must be created or migrated
first) goes through the repository, so the answers never differ, only the start-up.

The SQL mirrors the repository's: SQLAlchemy writes SQLite timestamps as naive UTC text
(``YYYY-MM-DD HH:MM:SS.ffffff``) and JSON columns as JSON text.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Iterable
from contextlib import closing
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from inkmotion.store.records import MIN_PREFIX, JobRecord, check_statuses

_FIELDS = tuple(JobRecord.__dataclass_fields__)
_TIMES = {"created_at", "started_at", "finished_at", "updated_at", "lease_until"}
_JSONS = {"spec", "losses", "metrics"}
_SELECT = f"SELECT {', '.join(_FIELDS)} FROM jobs"  # noqa: S608 - constant column names
SQLITE_TIMEOUT_S = 30.0  # as the repository's engine waits for a writer


def get_job(job_id: str, db_url: str | None = None) -> JobRecord | None:
    """The job with id ``job_id``, or ``None`` (as :func:`repository.get_job`)."""
    url = _db_url(db_url)
    conn = _connect(url)
    if conn is None:
        from inkmotion.store import repository

        return repository.get_job(job_id, url)
    with closing(conn):
        rows = conn.execute(f"{_SELECT} WHERE id = ?", (job_id,)).fetchall()
    return _record(rows[0]) if rows else None


def find_job(prefix: str, db_url: str | None = None) -> JobRecord | list[JobRecord] | None:
    """The job whose id starts with ``prefix`` (a full id or a unique prefix); a list when
    the prefix is ambiguous; ``None`` when nothing matches (as
    :func:`repository.find_job`)."""
    url = _db_url(db_url)
    exact = get_job(prefix, url)
    if exact is not None or len(prefix) < MIN_PREFIX:
        return exact
    conn = _connect(url)
    if conn is None:
        from inkmotion.store import repository

        return repository.find_job(prefix, url)
    pattern = prefix.replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_") + "%"
    with closing(conn):
        rows = conn.execute(f"{_SELECT} WHERE id LIKE ? ESCAPE '\\' LIMIT 10",
                            (pattern,)).fetchall()
    found = [_record(r) for r in rows]
    if not found:
        return None
    return found[0] if len(found) == 1 else found


def list_jobs(status: str | Iterable[str] | None = None, limit: int | None = 50,
              db_url: str | None = None) -> list[JobRecord]:
    """Jobs, newest first, optionally only those with the given status(es) (as
    :func:`repository.list_jobs`)."""
    statuses = None if status is None else check_statuses(status)
    url = _db_url(db_url)
    conn = _connect(url)
    if conn is None:
        from inkmotion.store import repository

        return repository.list_jobs(statuses, limit, url)
    sql, args = _SELECT, []
    if statuses is not None:
        sql += f" WHERE status IN ({', '.join('?' * len(statuses))})"
        args += statuses
    sql += " ORDER BY created_at DESC, id"
    if limit is not None:
        sql += " LIMIT ?"
        args.append(limit)
    with closing(conn):
        return [_record(r) for r in conn.execute(sql, args).fetchall()]


def sqlite_file(url: str) -> Path | None:
    """The file of a plain ``sqlite:///PATH`` URL (no driver, no query), else None."""
    prefix = "sqlite:///"
    if not url.startswith(prefix) or "?" in url or len(url) == len(prefix):
        return None
    path = url[len(prefix):]
    return None if path == ":memory:" else Path(path)


def _db_url(db_url: str | None) -> str:
    if db_url is not None:
        return db_url
    from inkmotion.settings import load_settings

    return load_settings().db_url


def _connect(url: str) -> sqlite3.Connection | None:
    """A connection to the SQLite store at ``url`` when it exists at the head revision;
    None where the repository must answer (another database, a new or older file)."""
    path = sqlite_file(url)
    if path is None or not path.is_file():
        return None
    try:
        conn = sqlite3.connect(f"{path.resolve().as_uri()}?mode=rw", uri=True,
                               timeout=SQLITE_TIMEOUT_S)
    except sqlite3.Error:
        return None
    from inkmotion.store.migrations import HEAD_REVISION

    try:
        revisions = [r for (r,) in conn.execute("SELECT version_num FROM alembic_version")]
    except sqlite3.Error:  # no such table: a database Alembic has not set up
        revisions = []
    if revisions != [HEAD_REVISION]:
        conn.close()
        return None
    return conn


def _record(row: tuple[Any, ...]) -> JobRecord:
    values = dict(zip(_FIELDS, row, strict=True))
    for name in _TIMES:
        values[name] = _timestamp(values[name])
    for name in _JSONS:
        if values[name] is not None:
            values[name] = json.loads(values[name])
    return JobRecord(**values)


def _timestamp(value: str | None) -> datetime | None:
    """SQLite's naive UTC text as a timezone-aware datetime (as ``UTCDateTime`` reads it)."""
    if value is None:
        return None
    return datetime.fromisoformat(value).replace(tzinfo=timezone.utc)
