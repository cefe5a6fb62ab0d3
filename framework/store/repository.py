"""Repository functions over the job table.

Every state change is one conditional ``UPDATE ... WHERE status IN (...)``, so concurrent
workers and the CLI never race through a read-modify-write: a function returns ``False``
when the job was not in a state that allows the change (e.g. it was cancelled meanwhile).
Records are returned as plain :class:`JobRecord` snapshots, detached from any session.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterable
from datetime import timedelta
from typing import Any

from sqlalchemy import and_, delete, or_, select, update
from sqlalchemy.orm import Session

from inkmotion.json_files import json_ready
from inkmotion.store.db import get_engine
from inkmotion.store.models import Job
from inkmotion.store.records import MIN_PREFIX, JobRecord, check_statuses, utcnow


def _record(job: Job) -> JobRecord:
    return JobRecord(**{f: getattr(job, f) for f in JobRecord.__dataclass_fields__})


def _db_url(db_url: str | None) -> str:
    if db_url is not None:
        return db_url
    from inkmotion.settings import load_settings

    return load_settings().db_url


def new_job_id() -> str:
    """A fresh job id (uuid4 hex, 32 characters); also the Celery task id."""
    return uuid.uuid4().hex


def create_job(spec: dict[str, Any], *, kind: str, queue: str, job_id: str | None = None,
               label: str = "", total: int = 0, db_url: str | None = None) -> JobRecord:
    """Record a new job as ``queued``; returns its record."""
    now = utcnow()
    job = Job(id=job_id or new_job_id(), kind=kind, queue=queue, status="queued", spec=spec,
              label=label[:255], step=0, total=total, created_at=now, updated_at=now,
              attempts=0)
    with Session(get_engine(_db_url(db_url))) as s, s.begin():
        s.add(job)
        s.flush()
        return _record(job)


def update_spec(job_id: str, spec: dict[str, Any], db_url: str | None = None) -> None:
    """Replace a queued job's spec (e.g. its input rewritten to the job's own copy)."""
    _update(job_id, ("queued",), db_url, spec=spec)


def get_job(job_id: str, db_url: str | None = None) -> JobRecord | None:
    """The job with id ``job_id``, or ``None``."""
    with Session(get_engine(_db_url(db_url))) as s:
        job = s.get(Job, job_id)
        return None if job is None else _record(job)


def find_job(prefix: str, db_url: str | None = None) -> JobRecord | list[JobRecord] | None:
    """The job whose id starts with ``prefix`` (a full id or a unique prefix); a list when
    the prefix is ambiguous; ``None`` when nothing matches."""
    exact = get_job(prefix, db_url)
    if exact is not None:
        return exact
    if len(prefix) < MIN_PREFIX:
        return None
    with Session(get_engine(_db_url(db_url))) as s:
        rows = s.scalars(select(Job).where(Job.id.like(f"{prefix}%")).limit(10)).all()
        found = [_record(j) for j in rows]
    if not found:
        return None
    return found[0] if len(found) == 1 else found


def list_jobs(status: str | Iterable[str] | None = None, limit: int | None = 50,
              db_url: str | None = None) -> list[JobRecord]:
    """Jobs, newest first, optionally only those with the given status(es)."""
    q = select(Job).order_by(Job.created_at.desc(), Job.id)
    if status is not None:
        q = q.where(Job.status.in_(check_statuses(status)))
    if limit is not None:
        q = q.limit(limit)
    with Session(get_engine(_db_url(db_url))) as s:
        return [_record(j) for j in s.scalars(q).all()]


def _update_where(db_url: str | None, *where: Any, **values: Any) -> bool:
    """One conditional ``UPDATE jobs SET values WHERE where``; True when it changed a row."""
    stmt = (update(Job).where(*where).values(**values)
            .execution_options(synchronize_session=False))
    with Session(get_engine(_db_url(db_url))) as s, s.begin():
        return s.execute(stmt).rowcount == 1


def _update(job_id: str, allowed: Iterable[str], db_url: str | None, **values: Any) -> bool:
    values.setdefault("updated_at", utcnow())
    return _update_where(db_url, Job.id == job_id, Job.status.in_(list(allowed)), **values)


def _owned(job_id: str, owner: str) -> tuple[Any, ...]:
    """The conditions "running under ``owner``'s lease"."""
    return (Job.id == job_id, Job.status == "running", Job.lease_owner == owner)


#: seconds a running attempt's lease lasts without a renewal (INKMOTION_LEASE_S overrides)
DEFAULT_LEASE_S = 30.0


def mark_running(job_id: str, worker_host: str, db_url: str | None = None, *,
                 owner: str | None = None, lease_s: float = DEFAULT_LEASE_S) -> bool:
    """A worker starts an attempt: status running, attempts + 1, its host, and the lease
    (``owner`` holds it for ``lease_s`` seconds). Allowed from queued, or from running
    when no live lease holds it (an attempt whose worker died, or a row without a lease).
    ``False`` otherwise: the job finished (cancelled, succeeded, failed) or another
    attempt holds a live lease: do not run it."""
    now = utcnow()
    free = or_(Job.status == "queued", and_(
        Job.status == "running", or_(Job.lease_until.is_(None), Job.lease_until < now)))
    return _update_where(db_url, Job.id == job_id, free, status="running",
                         attempts=Job.attempts + 1, worker_host=worker_host, started_at=now,
                         updated_at=now, step=0, error=None, lease_owner=owner,
                         lease_until=now + timedelta(seconds=lease_s))


def renew_lease(job_id: str, owner: str, db_url: str | None = None,
                lease_s: float = DEFAULT_LEASE_S) -> bool:
    """The heartbeat of attempt ``owner``: extend its lease by ``lease_s`` seconds from now.
    ``False`` when the job is no longer running under this owner (cancelled, finished,
    or re-queued after the lease expired): the attempt must stop and write nothing."""
    return _update_where(db_url, *_owned(job_id, owner),
                         lease_until=utcnow() + timedelta(seconds=lease_s))


def requeue_expired(db_url: str | None = None) -> list[JobRecord]:
    """Put every running job whose lease expired back to ``queued`` (one conditional
    update each, so when several reapers see the same job only one re-queues it) and
    return those this call re-queued; the caller sends them to their queue again."""
    now = utcnow()
    engine = get_engine(_db_url(db_url))
    with Session(engine) as s:
        candidates = s.scalars(select(Job.id).where(
            Job.status == "running", Job.lease_until.is_not(None),
            Job.lease_until < now)).all()
    requeued = []
    for job_id in candidates:
        won = _update_where(db_url, Job.id == job_id, Job.status == "running",
                            Job.lease_until < now, status="queued", lease_owner=None,
                            lease_until=None, updated_at=now)
        if won:
            record = get_job(job_id, db_url)
            if record is not None:
                requeued.append(record)
    return requeued


def claim_stranded(queues: Iterable[str], before: Any, db_url: str | None = None
                   ) -> list[tuple[JobRecord, Any]]:
    """The queued jobs on ``queues`` unchanged since before ``before`` (a datetime), each
    with its last change, taken by one conditional update (its ``updated_at`` set to now)
    so that of several idle workers one sends it again; :func:`unclaim` undoes it."""
    engine = get_engine(_db_url(db_url))
    with Session(engine) as s:
        rows = s.execute(select(Job.id, Job.updated_at).where(
            Job.status == "queued", Job.queue.in_(list(queues)),
            Job.updated_at < before)).all()
    claimed = []
    for job_id, changed in rows:
        if _update_where(db_url, Job.id == job_id, Job.status == "queued",
                         Job.updated_at == changed, updated_at=utcnow()):
            record = get_job(job_id, db_url)
            if record is not None:
                claimed.append((record, changed))
    return claimed


def unclaim(job_id: str, changed: Any, db_url: str | None = None) -> bool:
    """Undo :func:`claim_stranded` (its message could not be sent): ``updated_at`` back to
    ``changed``, so a later look takes it again."""
    return _update_where(db_url, Job.id == job_id, Job.status == "queued",
                         updated_at=changed)


def unsent(job_id: str, db_url: str | None = None) -> bool:
    """Undo :func:`requeue_expired` for a job whose message could not be sent (the broker
    away): running again with its lease expired and no owner, as before the reaper looked,
    so the next look re-queues and sends it. Queued without a message, nothing would ever
    send it (the broker's own redelivery comes hours later)."""
    return _update_where(db_url, Job.id == job_id, Job.status == "queued",
                         Job.lease_owner.is_(None), status="running",
                         lease_until=utcnow() - timedelta(seconds=1), updated_at=utcnow())


def release(job_id: str, owner: str, db_url: str | None = None) -> bool:
    """Attempt ``owner`` hands its running job back: status queued, no lease, at once (a
    worker shutting down). ``False`` when the job is no longer this attempt's."""
    return _update_where(db_url, *_owned(job_id, owner), status="queued", lease_owner=None,
                         lease_until=None, updated_at=utcnow())


def update_progress(job_id: str, step: int, total: int, losses: dict[str, float] | None = None,
                    t_end: float | None = None, db_url: str | None = None, *,
                    owner: str | None = None, lease_s: float = DEFAULT_LEASE_S) -> bool:
    """Record progress of a running job (and, for attempt ``owner``, renew its lease).
    ``False`` when it is no longer running (e.g. cancelled) or no longer this attempt's:
    the worker should stop."""
    if owner is None:
        return _update(job_id, ("running",), db_url, step=step, total=total, losses=losses,
                       t_end=t_end)
    now = utcnow()
    return _update_where(db_url, *_owned(job_id, owner), step=step, total=total,
                         losses=losses, t_end=t_end, updated_at=now,
                         lease_until=now + timedelta(seconds=lease_s))


def mark_succeeded(job_id: str, artifact_dir: str, db_url: str | None = None,
                   metrics: dict[str, Any] | None = None, owner: str | None = None) -> bool:
    """The job's artifacts are complete at ``artifact_dir``; ``metrics`` are the job kind's
    summary figures (e.g. ``{"chamfer_mean_px": 0.12}``), stored in the generic JSON column
    so that every job kind can report its own. They are normalised to plain JSON first
    (:func:`inkmotion.json_files.json_ready`), so a NumPy float cannot make the final
    update fail; an unserialisable value raises ``TypeError`` before anything is written.
    ``None`` leaves the column as it is. With ``owner``, only that attempt's lease may
    finish the job."""
    values: dict[str, Any] = {}
    if metrics is not None:
        values["metrics"] = json_ready(dict(metrics))
    now = utcnow()
    where = _owned(job_id, owner) if owner is not None else (Job.id == job_id,
                                                             Job.status == "running")
    return _update_where(db_url, *where, status="succeeded", artifact_dir=artifact_dir,
                         finished_at=now, updated_at=now, error=None, lease_owner=None,
                         lease_until=None, step=Job.total,  # complete, whatever the
                         **values)  # last progress write said (a fit whose tempo ladder
    # ended early ran fewer steps than it announced: its report.json says how many)


def mark_failed(job_id: str, error: str, db_url: str | None = None) -> bool:
    """The job failed for good with the one-sentence ``error``."""
    return _update(job_id, ("queued", "running"), db_url, status="failed", error=error,
                   finished_at=utcnow(), lease_owner=None, lease_until=None)


def mark_cancelled(job_id: str, db_url: str | None = None) -> bool:
    """Cancel a queued or running job; ``False`` when it had already finished."""
    return _update(job_id, ("queued", "running"), db_url, status="cancelled",
                   finished_at=utcnow(), lease_owner=None, lease_until=None)


def delete_job(job_id: str, db_url: str | None = None) -> bool:
    """Remove a job record (used when it could not be queued at all)."""
    with Session(get_engine(_db_url(db_url))) as s, s.begin():
        return s.execute(delete(Job).where(Job.id == job_id)).rowcount == 1
