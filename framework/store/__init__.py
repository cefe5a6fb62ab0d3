"""The job store: SQLAlchemy 2.x models, Alembic migrations and repository functions.

The database is ``INKMOTION_DB_URL`` (default: a SQLite file in the data directory); its
schema is upgraded to the latest Alembic revision on first use in a process (a database
already at the head revision costs one ``SELECT`` and never imports Alembic).
"""

from inkmotion.store.db import dispose_engines, get_engine, upgrade
from inkmotion.store.models import FINAL_STATUSES, STATUSES, Job
from inkmotion.store.repository import (
    JobRecord,
    create_job,
    delete_job,
    find_job,
    get_job,
    list_jobs,
    mark_cancelled,
    mark_failed,
    mark_running,
    mark_succeeded,
    new_job_id,
    release,
    renew_lease,
    requeue_expired,
    update_progress,
    update_spec,
)

__all__ = [
    "FINAL_STATUSES",
    "STATUSES",
    "Job",
    "JobRecord",
    "create_job",
    "delete_job",
    "dispose_engines",
    "find_job",
    "get_engine",
    "get_job",
    "list_jobs",
    "mark_cancelled",
    "mark_failed",
    "mark_running",
    "mark_succeeded",
    "new_job_id",
    "release",
    "renew_lease",
    "requeue_expired",
    "update_progress",
    "update_spec",
    "upgrade",
]
