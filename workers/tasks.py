"""The Celery task: run one recorded job with the same runner as ``inkmotion run``.

``inkmotion.run_job(job_id)``: load the record, mark it running (attempts + 1, worker
host), run :func:`inkmotion.jobs.shell.run_job` into ``<data>/jobs/<id>/artifacts``
(written atomically by the runner), mark it succeeded. A user error
(:class:`~inkmotion.errors.InkmotionError`) marks the job failed once with its sentence;
transient errors (database or broker connection) are retried with exponential backoff; a
cancelled job is not run. The attempt holds the job's lease and keeps it alive by
heartbeats (:mod:`inkmotion.workers.leases`): when its worker dies, any worker's reaper
queues the job again within a minute. A redelivered job resumes from the checkpoint the
dead attempt left in ``<data>/jobs/<id>/checkpoint.pt`` (the kinds that optimise a plan
checkpoint: fit, tag, abstract); the killed attempt left only a ``artifacts.partial-*``
folder, which is removed, so the job ends with exactly one result set.
"""

from __future__ import annotations

import logging
import random
import shutil
import socket
import time
import traceback
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from celery.exceptions import SoftTimeLimitExceeded
from celery.signals import (
    celeryd_after_setup,
    worker_process_init,
    worker_ready,
    worker_shutting_down,
)

from inkmotion.jobs.checkpoint import remove_checkpoint
from inkmotion.workers.app import TASK_NAME, app
from inkmotion.workers.leases import (
    SHUTDOWN,
    HandBack,
    Heartbeat,
    LeaseLost,
    attempt_owner,
    install_child_handler,
    on_worker_shutting_down,
    start_reaper,
)
from inkmotion.workers.progress import JobCancelled, StoreProgressObserver

log = logging.getLogger("inkmotion.workers")
MAX_RETRIES = 6


#: what every job on a worker imports besides its kind's own: the recording (rerun-sdk)
WORKER_MODULES = ("inkmotion.recording.recorder", "rerun")


def warm_up(instance: Any = None, **_: Any) -> None:
    """Celery's ``celeryd_after_setup`` (logging set up, ``-Q`` applied, the pool not yet
    started): import :data:`WORKER_MODULES` and what the run of each job kind on the
    queues this worker consumes imports (:func:`inkmotion.jobs.kind.warm_up_job_kinds`),
    so the first job runs as fast as the later ones; a prefork pool's processes, forked
    after, find it all imported."""
    import importlib

    from inkmotion.jobs.kind import warm_up_job_kinds

    started = time.perf_counter()
    for name in WORKER_MODULES:
        importlib.import_module(name)
    try:  # the queues after -Q (every queue the app declares without it)
        queues: set[str] | None = set(instance.app.amqp.queues.consume_from)
    except AttributeError:
        queues = None
    warmed, failed = warm_up_job_kinds(queues=queues)
    for sentence in failed:
        log.warning("worker: %s", sentence)
    log.info("worker: warmed up the job kinds %s in %.1f s", ", ".join(warmed) or "(none)",
             time.perf_counter() - started)


celeryd_after_setup.connect(warm_up)  # before the pool: its processes inherit it
worker_ready.connect(start_reaper)  # every worker process re-queues expired leases
worker_shutting_down.connect(on_worker_shutting_down)  # SIGTERM: hand the job back
worker_process_init.connect(install_child_handler)  # ... also from a prefork child


def transient_errors() -> tuple[type[BaseException], ...]:
    """Errors worth retrying: the database or the broker was briefly unreachable."""
    import kombu.exceptions
    import redis.exceptions
    import sqlalchemy.exc

    return (sqlalchemy.exc.OperationalError, sqlalchemy.exc.InterfaceError,
            sqlalchemy.exc.DisconnectionError, redis.exceptions.ConnectionError,
            redis.exceptions.TimeoutError, kombu.exceptions.OperationalError,
            ConnectionError, TimeoutError)


@contextmanager
def job_log(path: Path) -> Iterator[None]:
    """Append the worker's ``inkmotion`` log lines to the job's ``job.log`` meanwhile."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handler = logging.FileHandler(path, encoding="utf-8")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    logger = logging.getLogger("inkmotion")
    logger.addHandler(handler)
    previous = logger.level
    if logger.getEffectiveLevel() > logging.INFO:
        logger.setLevel(logging.INFO)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(previous)
        handler.close()


#: how long a final write (succeeded, failed) keeps retrying a briefly unreachable database
FINAL_WRITE_RETRY_S = 60.0


def with_db_retry(write: Any, *args: Any, **kwargs: Any) -> Any:
    """``write(*args, **kwargs)``, retried with backoff (0.5 s doubling to 8 s) for up to
    :data:`FINAL_WRITE_RETRY_S` seconds while the database is unreachable: the job's
    result is complete on disk and must be recorded by this attempt, not by a retry."""
    import sqlalchemy.exc

    deadline = time.monotonic() + FINAL_WRITE_RETRY_S
    delay = 0.5
    while True:
        try:
            return write(*args, **kwargs)
        except (sqlalchemy.exc.OperationalError, sqlalchemy.exc.InterfaceError) as exc:
            if time.monotonic() + delay > deadline:
                raise
            log.warning("job store unreachable (%s); retrying in %.1f s", exc, delay)
            time.sleep(delay)
            delay = min(8.0, 2 * delay)


def clean_stale_attempts(artifacts: Path) -> None:
    """Remove staging leftovers (``artifacts.partial-*``, ``artifacts.old-*``) of attempts
    that were killed; never the complete ``artifacts`` folder itself."""
    for stale in artifacts.parent.glob(f"{artifacts.name}.*-*"):
        shutil.rmtree(stale, ignore_errors=True)


def _worker_host(task: Any) -> str:
    return getattr(task.request, "hostname", None) or socket.gethostname()


#: the environment variable ``inkmotion worker --batch B`` sets for its processes
BATCH_ENV = "INKMOTION_WORKER_BATCH"


@app.task(name=TASK_NAME, bind=True, max_retries=MAX_RETRIES)
def run_job_task(self: Any, job_id: str, alone: bool = False) -> str:
    """Run the recorded job ``job_id``; returns its final status. ``alone``: never in a
    batch (a batch it was in failed, so it runs on its own)."""
    from inkmotion.settings import load_settings

    settings = load_settings()
    try:
        return _run(self, job_id, settings, alone)
    except transient_errors() as exc:
        if self.request.retries >= MAX_RETRIES:
            _give_up(job_id, settings, exc)
            return "failed"
        delay = min(60.0, 2.0 ** self.request.retries) * (0.5 + random.random())
        log.warning("job %s: transient error (%s); retry in %.1f s", job_id, exc, delay)
        raise self.retry(exc=exc, countdown=delay) from exc


def _give_up(job_id: str, settings: Any, exc: BaseException) -> None:
    """Retries exhausted: record the failure if the database lets us."""
    from inkmotion import store

    log.error("job %s: giving up after %d retries (%s)", job_id, MAX_RETRIES, exc)
    try:
        store.mark_failed(job_id, f"The job store or broker stayed unreachable after "
                                  f"{MAX_RETRIES} retries ({type(exc).__name__}); "
                                  "check the services and submit it again.", settings.db_url)
    except Exception:  # the database itself is down: the record stays as it was
        log.exception("job %s: could not record the failure", job_id)


def _run(task: Any, job_id: str, settings: Any, alone: bool = False) -> str:
    from inkmotion import store
    from inkmotion.errors import InkmotionError

    db = settings.db_url
    record = store.get_job(job_id, db)
    if record is None:
        log.error("job %s: no such record in %s; dropped", job_id, db)
        return "missing"
    if record.finished:
        log.info("job %s is already %s; not run", job_id, record.status)
        return record.status
    host = _worker_host(task)
    owner = attempt_owner(host)
    if not store.mark_running(job_id, host, db, owner=owner, lease_s=settings.lease_s):
        now = store.get_job(job_id, db)
        if now is not None and now.status == "running":
            log.info("job %s is running on %s under a live lease; not run twice", job_id,
                     now.worker_host)
            return "running"
        return "cancelled"
    job_dir = settings.job_dir(job_id)
    artifacts = job_dir / "artifacts"
    unwritable = _cannot_write(job_dir, host)
    if unwritable is not None:  # retried, it would fail the same way on every attempt
        log.error("job %s failed: %s", job_id, unwritable)
        store.mark_failed(job_id, unwritable, db)
        return "failed"
    with job_log(job_dir / "job.log"):
        attempt = (store.get_job(job_id, db) or record).attempts
        log.info("job %s: attempt %d on %s", job_id, attempt, host)
        clean_stale_attempts(artifacts)
        if (artifacts / "report.json").is_file():
            # a previous attempt completed the artifacts but died before recording it
            log.info("job %s: artifacts already complete from an earlier attempt", job_id)
            store.mark_succeeded(job_id, str(artifacts), db)
            return "succeeded"
        companions = [] if alone else _claim_companions(record, host, owner, settings)
        if companions:
            return _run_together([record, *companions], owner, settings)
        started = time.perf_counter()
        try:
            with Heartbeat(job_id, owner, db, settings.lease_s) as beat:
                report = _execute(job_id, record.spec, artifacts, db, owner, beat, settings)
        except JobCancelled:
            log.info("job %s: cancelled while running; stopped", job_id)
            remove_checkpoint(job_dir / "checkpoint.pt")  # never resumed: no dead weight
            return "cancelled"
        except HandBack:
            if store.release(job_id, owner, db):
                app.send_task(TASK_NAME, args=[job_id], queue=record.queue)
                log.info("job %s: the worker is shutting down; checkpointed and queued "
                         "again", job_id)
            return "handed-back"
        except LeaseLost:
            log.warning("job %s: this attempt lost its lease (another worker took the job "
                        "over); stopped without a result", job_id)
            return "lease-lost"
        except InkmotionError as exc:
            log.error("job %s failed: %s", job_id, exc)
            store.mark_failed(job_id, _as_named(str(exc), record.spec), db)
            remove_checkpoint(job_dir / "checkpoint.pt")
            return "failed"
        except SoftTimeLimitExceeded:
            msg = (f"The job ran past the time limit of {settings.soft_time_limit} s; "
                   "reduce --steps or raise INKMOTION_SOFT_TIME_LIMIT.")
            log.error("job %s failed: %s", job_id, msg)
            store.mark_failed(job_id, msg, db)
            remove_checkpoint(job_dir / "checkpoint.pt")
            return "failed"
        except transient_errors():
            raise
        except Exception as exc:
            log.error("job %s crashed:\n%s", job_id, traceback.format_exc())
            store.mark_failed(job_id, f"Internal error {type(exc).__name__}: {exc} "
                                      f"(see `inkmotion jobs logs {job_id}`).", db)
            return "failed"
        if not with_db_retry(store.mark_succeeded, job_id, str(artifacts), db,
                             metrics=report.get("metrics"), owner=owner):
            log.warning("job %s finished but its record was no longer running", job_id)
            return "cancelled"
        log.info("job %s succeeded in %.1f s", job_id, time.perf_counter() - started)
        return "succeeded"


def _as_named(message: str, spec: dict) -> str:
    """``message`` naming the job's input files as the user named them, not as the copies
    submit made under the data directory (:meth:`JobSpec.named_by_file`)."""
    from inkmotion.jobs.spec import JobSpec

    try:
        return JobSpec.from_dict(spec).named_by_file(message)
    except Exception:  # noqa: BLE001 - a spec that does not load fails with its own words
        return message


def _cannot_write(job_dir: Path, host: str) -> str | None:
    """Why worker ``host`` cannot write the job's folder (one sentence), or None. A data
    directory this worker cannot write (a mount read-only, another user's) raised before
    the job's log was open: the job went from running to stalled and back, every lease,
    its error never recorded."""
    try:
        job_dir.mkdir(parents=True, exist_ok=True)
        with open(job_dir / "job.log", "a", encoding="utf-8"):
            pass
    except OSError as exc:
        return (f"worker {host} cannot write the job's folder {job_dir} "
                f"({exc.strerror or type(exc).__name__}); give INKMOTION_DATA_DIR a folder "
                "every worker can write, then submit the job again.")
    return None


def _batch_size() -> int:
    import os

    value = os.environ.get(BATCH_ENV, "").strip()
    return int(value) if value.isdigit() and int(value) > 0 else 1


def _claim_companions(record: Any, host: str, owner: str, settings: Any) -> list[Any]:
    """Up to ``--batch`` − 1 queued jobs that can run in one batched optimisation with
    ``record`` (:func:`inkmotion.jobs.shell.batchable`: same kind, queue and parameters),
    oldest first, each taken by this attempt's lease as its own message would take it.
    Their messages, delivered later, find them running or finished and do nothing."""
    size = _batch_size()
    if size <= 1:
        return []
    from inkmotion import store
    from inkmotion.jobs.shell import batchable
    from inkmotion.jobs.spec import JobSpec

    try:
        spec = JobSpec.from_dict(record.spec)
        if not batchable([spec, spec]):
            return []
    except Exception:  # noqa: BLE001 - a bad spec fails in its own run, alone
        return []
    claimed = []
    queued = store.list_jobs(status="queued", limit=20 * size, db_url=settings.db_url)
    for other in sorted(queued, key=lambda r: r.created_at):
        if len(claimed) >= size - 1:
            break
        if other.id == record.id or other.queue != record.queue:
            continue
        if (settings.job_dir(other.id) / "artifacts" / "report.json").is_file():
            continue  # complete from an earlier attempt: its own message records it
        try:
            if not batchable([spec, JobSpec.from_dict(other.spec)]):
                continue
        except Exception:  # noqa: BLE001 - it fails in its own run
            continue
        if store.mark_running(other.id, host, settings.db_url, owner=owner,
                              lease_s=settings.lease_s):
            claimed.append(other)
    return claimed


def _localised(job_id: str, spec_dict: dict, artifacts: Path) -> Any:
    """The job's spec, its inputs read from the job's own storage where the original path
    is not mounted here."""
    from inkmotion.jobs.spec import JobSpec

    spec = JobSpec.from_dict(spec_dict, source=f"job {job_id}")
    for name, value in spec.inputs.items():
        local = artifacts.parent / "input" / name / Path(value).name
        if not Path(value).exists() and local.exists():
            spec.inputs[name] = str(local)  # the data directory is mounted elsewhere here
    return spec


def _run_together(records: list[Any], owner: str, settings: Any) -> str:
    """Run jobs (all running under ``owner``'s lease) as one batched optimisation, each
    with its own heartbeat, progress, checkpoint and result; the first is this task's.
    Should the batch stop (a cancel, a shutdown, a lost lease, an error), every job still
    ours goes back to its queue to run alone: none is lost, none runs twice."""
    from contextlib import ExitStack

    from inkmotion import store
    from inkmotion.errors import InkmotionError
    from inkmotion.jobs.shell import Together, run_jobs_together

    db = settings.db_url
    ids = [r.id for r in records]
    started = time.perf_counter()
    together = []
    try:
        with ExitStack() as stack:
            for r in records:
                artifacts = settings.job_dir(r.id) / "artifacts"
                clean_stale_attempts(artifacts)
                if r is not records[0]:  # the first job's log is open already
                    stack.enter_context(job_log(settings.job_dir(r.id) / "job.log"))
                beat = stack.enter_context(Heartbeat(r.id, owner, db, settings.lease_s))
                observer = StoreProgressObserver(r.id, db, owner=owner,
                                                 lease_s=settings.lease_s, lost=beat.lost,
                                                 shutdown=SHUTDOWN)
                together.append(Together(_localised(r.id, r.spec, artifacts), artifacts,
                                         [observer], recording_id=r.id,
                                         checkpoint=artifacts.parent / "checkpoint.pt"))
            log.info("job %s: a batch of %d (%s)", ids[0], len(ids),
                     ", ".join(i[:8] for i in ids))
            outcomes = run_jobs_together(together, record=True,
                                         checkpoint_every=settings.checkpoint_steps,
                                         checkpoint_s=settings.checkpoint_s,
                                         checkpoint_now=SHUTDOWN, fallback=False)
    except BaseException as exc:
        for r in records:
            if store.release(r.id, owner, db):
                app.send_task(TASK_NAME, args=[r.id], kwargs={"alone": True}, queue=r.queue)
        log.warning("job %s: the batch stopped (%s: %s); its jobs were queued again to run "
                    "alone", ids[0], type(exc).__name__, exc)
        if isinstance(exc, JobCancelled | HandBack | LeaseLost | SoftTimeLimitExceeded):
            return "handed-back"
        if isinstance(exc, Exception):
            return "requeued"
        raise
    status = "failed"
    for r, t, outcome in zip(records, together, outcomes, strict=True):
        if isinstance(outcome, BaseException):
            message = str(outcome) if isinstance(outcome, InkmotionError) else (
                f"Internal error {type(outcome).__name__}: {outcome} (see `inkmotion jobs "
                f"logs {r.id}`).")
            log.error("job %s failed: %s", r.id, message)
            store.mark_failed(r.id, message, db)
            continue
        if t.checkpoint is not None:
            remove_checkpoint(t.checkpoint)
        done = with_db_retry(store.mark_succeeded, r.id, str(t.out_dir), db,
                             metrics=outcome.get("metrics"), owner=owner)
        if r.id == ids[0] and done:
            status = "succeeded"
    log.info("batch of %d finished in %.1f s", len(ids), time.perf_counter() - started)
    return status


def _execute(job_id: str, spec_dict: dict, artifacts: Path, db: str, owner: str,
             beat: Heartbeat, settings: Any) -> dict:
    from inkmotion.jobs.shell import run_job

    spec = _localised(job_id, spec_dict, artifacts)
    observer = StoreProgressObserver(job_id, db, owner=owner, lease_s=settings.lease_s,
                                     lost=beat.lost, shutdown=SHUTDOWN)
    checkpoint = artifacts.parent / "checkpoint.pt"  # in the job's storage, not the staging
    report = run_job(spec, artifacts, observers=[observer], record=True, recording_id=job_id,
                     checkpoint=checkpoint, checkpoint_every=settings.checkpoint_steps,
                     checkpoint_s=settings.checkpoint_s, checkpoint_now=SHUTDOWN)
    remove_checkpoint(checkpoint)  # the result is complete: nothing to resume
    return report
