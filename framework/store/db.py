"""Engines for the job store, SQLite pragmas, and Alembic migrations on first use.

One engine per database URL and process (a cache, not state: the same URL always gives an
equivalent engine). The schema is brought to the latest Alembic revision the first time a
URL is used in a process; concurrent first uses from several workers are serialised by a
file lock (SQLite) or an advisory lock (PostgreSQL).

Start-up matters (``inkmotion jobs list`` should answer at once), and importing Alembic and
loading its scripts costs about 0.25 s, so the first use first reads ``alembic_version``
with plain SQLAlchemy: a database already at :data:`HEAD_REVISION` is used as is, and only
a new or stale one goes through ``alembic upgrade`` (locks included).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import OperationalError, ProgrammingError

from inkmotion.store.migrations import HEAD_REVISION

MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"
SQLITE_BUSY_TIMEOUT_MS = 30_000


def _sqlite_pragmas(dbapi_connection: Any, connection_record: Any) -> None:
    """WAL lets readers run beside one writer; busy_timeout makes writers wait, not fail."""
    cur = dbapi_connection.cursor()
    cur.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_MS}")
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA synchronous=NORMAL")
    cur.close()


def _sqlite_path(url: str) -> Path | None:
    u = make_url(url)
    if u.get_backend_name() != "sqlite" or not u.database or u.database == ":memory:":
        return None
    return Path(u.database)


def alembic_config() -> Any:
    """An Alembic :class:`~alembic.config.Config` pointing at the packaged migrations."""
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    return cfg


@contextmanager
def _migration_lock(url: str) -> Iterator[None]:
    path = _sqlite_path(url)
    if path is None:
        yield
        return
    import fcntl

    with open(path.with_name(path.name + ".migrate.lock"), "a+") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def upgrade(engine: Engine, revision: str = "head") -> None:
    """Run ``alembic upgrade <revision>`` on ``engine``'s database."""
    import logging

    from alembic import command

    logging.getLogger("alembic").setLevel(logging.WARNING)  # no INFO chatter per process
    url = engine.url.render_as_string(hide_password=False)
    with _migration_lock(url), engine.begin() as conn:
        if conn.dialect.name == "postgresql":
            conn.execute(text("SELECT pg_advisory_xact_lock(727001)"))
        cfg = alembic_config()
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, revision)


def schema_revisions(engine: Engine) -> tuple[str, ...] | None:
    """The Alembic revisions ``engine``'s database is at, read with plain SQLAlchemy.

    ``None`` when there is no ``alembic_version`` table yet (a new database). Reading it
    this way, rather than through Alembic, keeps Alembic out of processes that need no
    migration."""
    try:
        with engine.connect() as conn:
            rows = conn.execute(text("SELECT version_num FROM alembic_version")).scalars()
            return tuple(sorted(rows))
    except (OperationalError, ProgrammingError):  # no such table (or no database yet)
        return None


def schema_is_current(engine: Engine) -> bool:
    """Whether ``engine``'s database is exactly at the packaged head revision, so that
    ``alembic upgrade head`` would do nothing and can be skipped."""
    return schema_revisions(engine) == (HEAD_REVISION,)


def get_engine(url: str, migrate: bool = True) -> Engine:
    """The engine for ``url``, its schema upgraded to the latest revision (once per process).

    With ``migrate`` a database already at :data:`HEAD_REVISION` costs one ``SELECT``;
    any other (new, older, or one Alembic must judge) is upgraded by :func:`upgrade`.
    Engines are cached per process id, so a forked child (Celery prefork) never reuses
    its parent's connections."""
    key = (os.getpid(), url, migrate)
    engine = _ENGINES.get(key)
    if engine is None:
        engine = _ENGINES[key] = _create(url, migrate)
    return engine


def _create(url: str, migrate: bool) -> Engine:
    """A new engine for ``url`` (:func:`get_engine`); a URL SQLAlchemy cannot use is a
    :class:`~inkmotion.errors.ServiceError` in one sentence naming ``INKMOTION_DB_URL``
    (password hidden). A database that cannot be reached raises SQLAlchemy's own error,
    which a worker retries (:func:`unreachable` words it for the command line)."""
    from sqlalchemy.exc import ArgumentError, NoSuchModuleError

    from inkmotion.errors import ServiceError

    shown = _shown(url)
    path = _sqlite_path(url)
    kwargs: dict[str, Any] = {"pool_pre_ping": True}
    try:
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            kwargs["connect_args"] = {"timeout": SQLITE_BUSY_TIMEOUT_MS / 1000}
        engine = create_engine(url, **kwargs)
    except (ArgumentError, NoSuchModuleError, ImportError) as exc:
        raise ServiceError(
            f"INKMOTION_DB_URL={shown} is not a job store this can open ({_reason(exc)}); "
            "give sqlite:////PATH/jobs.sqlite3 or postgresql+psycopg://USER:PASSWORD@HOST/DB."
        ) from None
    except OSError as exc:
        raise ServiceError(f"INKMOTION_DB_URL={shown}: its folder cannot be made "
                           f"({_reason(exc)}); give a folder you can write.") from None
    if engine.dialect.name == "sqlite":
        event.listen(engine, "connect", _sqlite_pragmas)
    if migrate and not schema_is_current(engine):
        upgrade(engine)
    return engine


def unreachable(exc: BaseException, url: str) -> str:
    """One sentence for a command line whose job store at ``url`` could not be reached or
    written (``exc``, a SQLAlchemy error; a worker retries such errors instead)."""
    return (f"the job store INKMOTION_DB_URL={_shown(url)} cannot be used ({_reason(exc)}); check "
            "the URL, that the database is running and that it can be written.")


def _shown(url: str) -> str:
    """``url`` as a message may show it: its password hidden."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        return make_url(url).render_as_string(hide_password=True)
    except ArgumentError:
        return url.split("@")[-1]


def _reason(exc: BaseException) -> str:
    """The first line of an error, short (a driver's message can run to pages)."""
    text = str(getattr(exc, "orig", None) or exc).strip().splitlines()
    return (text[0] if text else type(exc).__name__)[:160]


def dispose_engines() -> None:
    """Close every cached engine of this process (tests, shutdown)."""
    for key in [k for k in _ENGINES if k[0] == os.getpid()]:
        _ENGINES.pop(key).dispose()


_ENGINES: dict[tuple[int, str, bool], Engine] = {}  # cache: (pid, url, migrate) -> engine
