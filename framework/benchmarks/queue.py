"""Queue benchmark: a batch of fit jobs through a real Redis and real Celery workers.

Everything runs on this machine and is thrown away afterwards: a redis-server on a free
loopback port, a temporary data directory with its SQLite job store, and ``workers``
worker subprocesses (solo pool, ``OMP_NUM_THREADS=1`` each; by default 200 short jobs
— 5 steps at 96 px — on 4 workers), all from
:mod:`inkmotion.workers.local`. ``jobs`` ``text:WORD`` fit jobs are queued at once through
:func:`inkmotion.workers.submit.submit_specs` (what ``inkmotion submit`` calls); the
figures come from the job records and the job folders once every job has finished:

========================  ==============================================================
queue_jobs                jobs submitted
queue_succeeded           jobs that ended ``succeeded``
queue_lost                jobs not finished when the benchmark gave up waiting
queue_completed_twice     jobs run more than once (attempts > 1), or whose folder holds
                          more than one artifacts set or a ``*.partial-*`` leftover
queue_missing_artifacts   succeeded jobs without a complete ``artifacts/report.json``
queue_jobs_per_min        succeeded jobs / (last finished − first created)
queue_latency_*_s         queue-to-start latency (started − created): of the first job
                          queued (an idle pool), the median, the 95th percentile and the
                          maximum (queue wait included: with more jobs than workers most
                          jobs wait)
queue_run_median_s        median run time of a job on a worker (finished − started)
========================  ==============================================================
"""

from __future__ import annotations

import os
import shutil
import statistics
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from inkmotion.errors import ServiceError

if TYPE_CHECKING:
    from inkmotion.store import JobRecord

#: the inputs, ``text:WORD``, taken in turn
WORDS = ("ink", "motion", "hello", "world", "robot", "arm", "pen", "line", "curve", "draw",
         "speed", "time", "human", "sigma", "tag", "art", "wave", "loop", "star", "moon")
POLL_S = 0.25


@contextmanager
def _environment(values: dict[str, str]) -> Iterator[None]:
    """Set environment variables for the block; restore the previous values after."""
    previous = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in previous.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def bench_queue(jobs: int = 200, workers: int = 4, steps: int = 5, size: int = 96, *,
                timeout_s: float = 1800.0, concurrency: int = 1,
                threads: int | None = None) -> dict[str, float]:
    """Queue ``jobs`` fit jobs (``steps`` steps, ``size`` px) on ``workers`` local workers,
    wait up to ``timeout_s`` seconds for them, and return the figures of the module
    docstring; ``concurrency`` > 1: each worker a prefork pool of that many slots (the
    thread policy of :mod:`inkmotion.devices` for them); ``threads``: torch threads per
    job (INKMOTION_THREADS; default: the pool's). Raises
    :class:`~inkmotion.errors.ServiceError` when ``redis-server`` is not installed."""
    from inkmotion import store
    from inkmotion.jobs.spec import JobSpec
    from inkmotion.settings import load_settings
    from inkmotion.workers.local import WorkerPool, redis_binary, start_redis
    from inkmotion.workers.submit import submit_specs

    if redis_binary() is None:
        raise ServiceError("The queue benchmark needs redis-server, which is not installed; "
                           "install it with `apt-get install redis-server`.")
    tmp = Path(tempfile.mkdtemp(prefix="inkmotion-bench-queue-"))
    data = tmp / "data"
    redis = None
    pool = None
    try:
        redis = start_redis(tmp / "redis")
        env = {"INKMOTION_DATA_DIR": str(data),
               "INKMOTION_DB_URL": f"sqlite:///{data / 'jobs.sqlite3'}",
               "INKMOTION_BROKER_URL": redis.url,
               **({"INKMOTION_THREADS": str(threads)} if threads else {})}
        with _environment(env):
            settings = load_settings()
            store.get_engine(settings.db_url)  # create the schema once, before the workers
            pool = WorkerPool(env, tmp / "logs", concurrency=concurrency)
            pool.ensure(tuple(f"w{i + 1}" for i in range(workers)))
            specs = [JobSpec("fit", {"drawing": f"text:{WORDS[i % len(WORDS)]}"}, device="cpu",
                             params={"steps": steps, "size": size}) for i in range(jobs)]
            ids = [r.id for r in submit_specs(specs, settings)]
            deadline = time.monotonic() + timeout_s
            pending = set(ids)
            while pending and time.monotonic() < deadline:
                time.sleep(POLL_S)
                for job_id in list(pending):
                    record = store.get_job(job_id, settings.db_url)
                    if record is not None and record.finished:
                        pending.discard(job_id)
            records = [store.get_job(i, settings.db_url) for i in ids]
            return _figures([r for r in records if r is not None], settings.jobs_dir,
                            jobs=jobs, workers=workers, steps=steps)
    finally:
        if pool is not None:
            pool.stop_all()
        if redis is not None:
            redis.stop()
        from inkmotion.store import dispose_engines

        dispose_engines()
        shutil.rmtree(tmp, ignore_errors=True)


def _percentile(values: list[float], q: float) -> float:
    """The ``q``-th percentile (linear interpolation between order statistics); NaN for
    no values."""
    if not values:
        return float("nan")
    import numpy as np

    return float(np.percentile(values, q))


def _figures(records: list[JobRecord], jobs_dir: Path, *, jobs: int, workers: int,
             steps: int) -> dict[str, float]:
    """The benchmark's figures from the final job records and their folders."""
    nan = float("nan")
    succeeded = [r for r in records if r.status == "succeeded"]
    twice = missing = 0
    for r in records:
        job_dir = jobs_dir / r.id
        sets = [p for p in job_dir.glob("artifacts*") if p.is_dir()]
        partial = list(job_dir.glob("*.partial-*"))
        if r.attempts > 1 or len(sets) > 1 or partial:
            twice += 1
        if r.status == "succeeded" and not (job_dir / "artifacts" / "report.json").is_file():
            missing += 1
    started = [r for r in records if r.started_at is not None]
    latency = [(r.started_at - r.created_at).total_seconds() for r in started]
    first = min(records, key=lambda r: r.created_at) if records else None
    run = [(r.finished_at - r.started_at).total_seconds() for r in succeeded
           if r.finished_at is not None and r.started_at is not None]
    if succeeded:
        span = (max(r.finished_at for r in succeeded)
                - min(r.created_at for r in records)).total_seconds()
        per_min = 60.0 * len(succeeded) / span if span > 0 else nan
    else:
        per_min = nan
    return {
        "queue_jobs": jobs,
        "queue_workers": workers,
        "queue_steps": steps,
        "queue_succeeded": len(succeeded),
        "queue_lost": sum(1 for r in records if not r.finished) + (jobs - len(records)),
        "queue_completed_twice": twice,
        "queue_missing_artifacts": missing,
        "queue_jobs_per_min": per_min,
        "queue_latency_first_s": (
            (first.started_at - first.created_at).total_seconds()
            if first is not None and first.started_at is not None else nan),
        "queue_latency_median_s": statistics.median(latency) if latency else nan,
        "queue_latency_p95_s": _percentile(latency, 95),
        "queue_latency_max_s": max(latency) if latency else nan,
        "queue_run_median_s": statistics.median(run) if run else nan,
    }
