"""The job store: SQLAlchemy 2.x models, Alembic migrations and repository functions.

The database is ``INKMOTION_DB_URL`` (default: a SQLite file in the data directory); its
schema is upgraded to the latest Alembic revision on first use in a process (a database
already at the head revision costs one ``SELECT`` and never imports Alembic).

The names load on first access (:mod:`inkmotion.lazy`), and the read-only queries
(:func:`get_job`, :func:`find_job`, :func:`list_jobs`) are those of
:mod:`inkmotion.store.reads`, which read a current SQLite store without SQLAlchemy: the
command line's ``jobs list`` pays for neither.
"""

from inkmotion.lazy import lazy_names

_DEFINED_IN = {
    "dispose_engines": "db", "get_engine": "db", "upgrade": "db",
    "FINAL_STATUSES": "records", "STATUSES": "records", "JobRecord": "records",
    "Job": "models",
    "find_job": "reads", "get_job": "reads", "list_jobs": "reads",
    **{name: "repository" for name in (
        "claim_stranded", "create_job", "delete_job", "mark_cancelled", "mark_failed",
        "mark_running", "unclaim",
        "mark_succeeded", "new_job_id", "release", "renew_lease", "requeue_expired",
        "unsent", "update_progress", "update_spec")},
}

__all__ = sorted(_DEFINED_IN)

__getattr__, __dir__ = lazy_names(
    __name__, {name: f"{__name__}.{module}" for name, module in _DEFINED_IN.items()},
    globals(), __all__)
