"""Queue jobs for the workers: validate, copy inputs into the job's storage, record, publish.

Nothing is left recorded as ``queued`` unless its message reached the broker: the broker
is checked first, and a record whose publication fails is deleted again.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from inkmotion.errors import InputError, ServiceError
from inkmotion.jobs.spec import JobSpec
from inkmotion.settings import Settings, load_settings, redact_url
from inkmotion.store import JobRecord

CONNECT_TIMEOUT_S = 3.0


def broker_unreachable(url: str, reason: object = "") -> ServiceError:
    """The one-sentence error for a broker that cannot be reached."""
    why = f" ({reason})" if str(reason) else ""
    return ServiceError(
        f"Cannot reach the broker at {redact_url(url)}{why}; start Redis with `redis-server` "
        "(or `docker compose -f deploy/docker-compose.yml up -d redis`) or point "
        "INKMOTION_BROKER_URL at a running one.")


def _connection(settings: Settings) -> Any:
    from inkmotion.workers.app import app

    return app.connection_for_write(settings.broker_url, connect_timeout=CONNECT_TIMEOUT_S)


def check_broker(settings: Settings | None = None) -> None:
    """Raise :class:`ServiceError` (one sentence) unless the broker answers now."""
    settings = settings or load_settings()
    try:
        with _connection(settings) as conn:
            conn.ensure_connection(max_retries=1, interval_start=0, interval_step=0.2,
                                   timeout=CONNECT_TIMEOUT_S)
    except Exception as exc:  # kombu wraps socket errors in several types
        raise broker_unreachable(settings.broker_url, _short(exc)) from exc


def _short(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return text[:160]


def _input_files(spec: JobSpec) -> dict[str, Path]:
    """The spec's inputs that are local files (not ``scheme:value`` sources nor text)."""
    from inkmotion.inputs.sources import is_scheme
    from inkmotion.jobs.kind import job_kind

    forms = {i.name: i.form for i in job_kind(spec.kind).inputs}
    return {name: Path(value) for name, value in spec.inputs.items()
            if forms.get(name) != "text" and not is_scheme(value) and Path(value).is_file()}


def check_input_size(spec: JobSpec, settings: Settings) -> None:
    """Refuse an input file above ``settings.max_input_bytes`` with one sentence."""
    for path in _input_files(spec).values():
        size = path.stat().st_size
        if size > settings.max_input_bytes:
            raise InputError(
                f"{path}: {size / 2**20:.1f} MB is above the "
                f"{settings.max_input_bytes / 2**20:.0f} MB input limit; shrink the file or "
                "raise INKMOTION_MAX_INPUT_MB.")


def copy_input(spec: JobSpec, job_dir: Path, settings: Settings) -> JobSpec:
    """A copy of ``spec`` whose input files live in ``job_dir/input/`` (other inputs are
    kept as they are). Refuses files above ``settings.max_input_bytes``."""
    check_input_size(spec, settings)
    out = spec.copy()
    for name, src in _input_files(spec).items():
        dest = job_dir / "input" / name / src.name
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, dest)
        out.inputs[name] = str(dest.resolve())
    return out


def submit_specs(specs: list[JobSpec], settings: Settings | None = None) -> list[JobRecord]:
    """Validate every spec, then queue one job per spec; returns their records.

    Raises :class:`~inkmotion.errors.InkmotionError` before anything is recorded when a
    spec is invalid, an input is one its kind's run would refuse (the kind's
    ``check_inputs``: a malformed or truncated file, a blank picture), or the broker is
    unreachable.
    """
    from inkmotion import store
    from inkmotion.jobs.kind import resolve
    from inkmotion.workers.app import TASK_NAME, app

    settings = settings or load_settings()
    resolved = [resolve(spec) for spec in specs]
    for spec in specs:
        check_input_size(spec, settings)
    for job in resolved:
        check_inputs = getattr(job.kind, "check_inputs", None)
        if check_inputs is not None:  # a worker would refuse it: say so now, queue nothing
            check_inputs(job)
    check_broker(settings)
    records: list[JobRecord] = []
    with _connection(settings) as conn:
        for spec, job in zip(specs, resolved, strict=True):
            job_id = store.new_job_id()
            job_dir = settings.job_dir(job_id)
            queue = job.kind.queue
            record = None
            try:
                stored = copy_input(spec, job_dir, settings)
                record = store.create_job(stored.to_dict(), kind=spec.kind, queue=queue,
                                          job_id=job_id, label=spec.label[:255],
                                          total=int(job.kind.steps(job.params)),
                                          db_url=settings.db_url)
                app.send_task(TASK_NAME, args=[job_id], task_id=job_id, queue=queue,
                              connection=conn, retry=False)
            except Exception as exc:
                if record is not None:
                    store.delete_job(job_id, settings.db_url)
                shutil.rmtree(job_dir, ignore_errors=True)
                if _is_broker_error(exc):
                    raise broker_unreachable(settings.broker_url, _short(exc)) from exc
                if isinstance(exc, OSError):
                    raise ServiceError(
                        f"the job's files cannot be written under INKMOTION_DATA_DIR="
                        f"{settings.data_dir} ({_short(exc)}); give a folder this user can "
                        "write (the workers must read it too).") from exc
                raise
            records.append(record)
    return records


def _is_broker_error(exc: BaseException) -> bool:
    import kombu.exceptions
    import redis.exceptions

    return isinstance(exc, (kombu.exceptions.OperationalError, redis.exceptions.RedisError,
                            ConnectionError, TimeoutError))


def cancel_job(job_id: str, settings: Settings | None = None) -> tuple[bool, str | None]:
    """Mark the job cancelled and ask the workers to revoke it (terminating it if it is
    running). Returns (whether it was cancelled now, a warning or ``None``). A running job
    on a worker that cannot be signalled stops at its next progress update."""
    from inkmotion import store

    settings = settings or load_settings()
    if not store.mark_cancelled(job_id, settings.db_url):
        return False, None
    try:
        check_broker(settings)
        from inkmotion.workers.app import app

        with _connection(settings) as conn:
            app.control.revoke(job_id, terminate=True, signal="SIGTERM", connection=conn)
    except ServiceError as exc:
        return True, f"recorded as cancelled, but {exc}"
    return True, None
