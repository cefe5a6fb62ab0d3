"""The studio's jobs: run here in worker processes, or queued for the workers; followed live.

Every job the studio starts is a row of the job store (:mod:`inkmotion.store`) with its
folder under the data directory (``<data>/jobs/<id>/input`` and ``artifacts``), exactly as
``inkmotion submit`` records one, so ``inkmotion jobs list`` and the studio's jobs page
show the same jobs, and a job outlives the page that started it.

- **Here** (the default): the job runs in one of :attr:`Runner.slots` processes the studio
  spawns and warms up when it starts (:func:`warm_up`; fits in threads of one process share
  its interpreter lock: two at once took 1.9-2.0x as long), through the job shell
  (:func:`inkmotion.jobs.shell.run_job`, atomic artifacts), while holding the store lease
  the workers hold (:class:`~inkmotion.workers.leases.Heartbeat`), so a studio that dies
  mid-job leaves a ``running`` row whose lease expires and any worker's reaper queues it
  again: nothing is lost. At most :attr:`Runner.slots` jobs run at once (the machine's
  cores over a job's threads); the others wait their turn as ``queued``. Its events come
  back through a queue of a multiprocessing manager, its cancel flag goes out through one.
- **On the workers** (``inkmotion studio --workers``): the job goes through
  :func:`inkmotion.workers.submit.submit_specs`, and its progress is read from the store.

A page follows a job through :meth:`Runner.events`: the store's progress, and for a job
running here the live figures and the current drawing a few times a second
(:class:`LiveObserver`). Closing the page stops nothing: the job finishes and is listed;
cancelling it stops it at its next step and leaves no artifacts.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import socket
import threading
import time
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from inkmotion.events import RunContext, StepState
from inkmotion.jobs.spec import JobSpec
from inkmotion.settings import Settings

log = logging.getLogger("inkmotion.studio")

#: seconds between two live figures (and current drawings) of a running job
LIVE_EVERY_S = 0.25
#: points kept per path of a live drawing (the page redraws it; the result has them all)
LIVE_POINTS = 400


class JobCancelled(Exception):
    """Raised in a job's thread at the step after the page cancelled it."""


@dataclass
class Live:
    """What a page can see of a job that runs here: its event list (appended by the
    thread that drains its process's queue, read by the page's stream) and its cancel
    flag (a manager's Event: the job's process reads it)."""

    job_id: str
    cancel: Any
    events: list[dict[str, Any]] = field(default_factory=list)
    done: threading.Event = field(default_factory=threading.Event)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def emit(self, event: dict[str, Any]) -> None:
        with self.lock:
            self.events.append(event)

    def since(self, index: int) -> list[dict[str, Any]]:
        with self.lock:
            return self.events[index:]


class LiveObserver:
    """Job observer: the figures and the current drawing of the running job, every
    :data:`LIVE_EVERY_S` seconds, into its :class:`Live` event list; stops the job with
    :class:`JobCancelled` once its cancel flag is set. It reads the device only when it
    emits (a few times a second), never on the other steps."""

    def __init__(self, live: Live) -> None:
        self.live = live
        self._last = 0.0
        self._latest: StepState | None = None  # the job's latest step

    def _due(self) -> bool:
        return time.monotonic() - self._last >= LIVE_EVERY_S

    def wants_geometry(self, step: int) -> bool:
        return self._due()

    def on_start(self, ctx: RunContext) -> None:
        traces = [_thin(t[:, :2]) for t in ctx.traces] if ctx.traces else []
        self.live.emit({"type": "start", "total": int(ctx.total_steps),
                        "canvas": [int(ctx.canvas[0]), int(ctx.canvas[1])],
                        "traces": traces})

    def on_step(self, state: StepState) -> None:
        if self.live.cancel.is_set():
            raise JobCancelled(self.live.job_id)
        self._latest = state
        if not (self._due() or state.step == state.total):
            return
        self._emit(state)

    def on_end(self, report: dict) -> None:
        """A job that ended before the steps it announced (a fit's tempo ladder that ended
        early) sends its last step once more, as the step count's end."""
        if self._latest is not None and self._latest.step != self._latest.total:
            self._emit(self._latest, ended=True)

    def _emit(self, state: StepState, ended: bool = False) -> None:
        self._last = time.monotonic()
        event: dict[str, Any] = {"type": "step", "step": int(state.step),
                                 "total": int(state.step if ended else state.total)}
        shown = state.shown()
        if shown:
            from inkmotion.events import scalars

            numbers = {k: v for k, v in shown.items()
                       if v is not None and (hasattr(v, "detach") or isinstance(v, int | float))}
            event["figures"] = {k: _finite(v) for k, v in scalars(numbers).items()}
            event["words"] = {k: str(v) for k, v in shown.items() if isinstance(v, str)}
        if state.positions:
            event["paths"] = [_thin(_numpy(p)[:, :2]) for p in state.positions]
        self.live.emit(event)


def _numpy(x: Any) -> Any:
    return x.detach().cpu().numpy() if hasattr(x, "detach") else x


def _thin(points: Any) -> list[list[float]]:
    """At most :data:`LIVE_POINTS` of ``points`` (evenly picked), rounded to 0.1 px."""
    import numpy as np

    pts = np.asarray(points, dtype=float)
    if len(pts) > LIVE_POINTS:
        pts = pts[np.linspace(0, len(pts) - 1, LIVE_POINTS).round().astype(int)]
    return np.round(pts, 1).tolist()


def _finite(v: float) -> float | None:
    import math

    return v if math.isfinite(v) else None


def start_job_process(db_url: str, warmed: Any) -> None:
    """A job process's start: Ctrl-C is the studio's to handle (it cancels the jobs, which
    then end cleanly, recorded as cancelled), :func:`warm_up`, and a first query of the
    job store at ``db_url`` (its engine made, its schema checked: 0.5 s the first time);
    then its pid goes on the shared list ``warmed``."""
    from inkmotion.store import list_jobs

    _ignore_ctrl_c()
    warm_up()
    list_jobs(limit=1, db_url=db_url)
    warmed.append(os.getpid())


def _ignore_ctrl_c() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def warm_up() -> None:
    """Run a 2-step fit of one letter into a temporary folder: the imports (torch, the
    plugins, rerun) and the first calls of a job cost about 4 s once per process; paid
    here, the first Fit pressed shows progress at once."""
    import tempfile

    from inkmotion.jobs.shell import run_job

    with tempfile.TemporaryDirectory(prefix="inkmotion-warm-up-") as folder:
        run_job(JobSpec(kind="fit", inputs={"drawing": "text:a"}, params={"steps": 2}),
                Path(folder) / "out", record=True)


def default_slots(threads: int) -> int:
    """Jobs run at once here: the machine's cores over a job's threads (at least one)."""
    return max(1, (os.cpu_count() or 1) // max(1, threads))


class Runner:
    """Starts, follows and cancels the studio's jobs (module docstring)."""

    def __init__(self, settings: Settings, *, workers: bool = False,
                 slots: int | None = None) -> None:
        from inkmotion.devices import default_threads

        self.settings = settings
        self.workers = workers
        self.slots = slots or default_slots(default_threads())
        self._manager: Any = None
        self._pool: ProcessPoolExecutor | None = None
        self._warmed: Any = []
        if not workers:
            # one process per slot (spawned once, warmed up): fits in threads of one
            # process share its interpreter lock and ran 1.9-2.0x slower two at a time
            from multiprocessing.managers import SyncManager

            context = multiprocessing.get_context("spawn")
            self._manager = SyncManager(ctx=context)
            self._manager.start(_ignore_ctrl_c)  # it outlives the jobs it carries events for
            self._warmed = self._manager.list()  # a job process's pid once it is warm
            self._pool = ProcessPoolExecutor(self.slots, mp_context=context,
                                             initializer=start_job_process,
                                             initargs=(settings.db_url, self._warmed))
            for _ in range(self.slots):  # start them now, not at the first Fit
                self._pool.submit(_nothing)
        self._live: dict[str, Live] = {}
        self._futures: dict[str, Future] = {}
        self._lock = threading.Lock()
        self.host = socket.gethostname()

    @property
    def ready(self) -> bool:
        """Whether every job process has started and warmed up (a Fit now shows progress
        at once); always with ``--workers``."""
        return self._pool is None or len(self._warmed) >= self.slots

    # -- starting ------------------------------------------------------------------------
    def start(self, spec: JobSpec) -> str:
        """Validate and record ``spec`` (its input files copied into the job's folder), then
        run it here or queue it for the workers; returns its id. Raises
        :class:`~inkmotion.errors.InkmotionError` (one sentence) before anything is
        recorded when the spec is invalid or the broker unreachable."""
        if self.workers:
            from inkmotion.workers.submit import submit_specs

            return submit_specs([spec], self.settings)[0].id
        import shutil

        from inkmotion import store
        from inkmotion.jobs.kind import resolve
        from inkmotion.jobs.shell import with_threads
        from inkmotion.workers.submit import copy_input

        spec = with_threads(spec)
        job = resolve(spec)
        job_id = store.new_job_id()
        job_dir = self.settings.job_dir(job_id)
        try:
            stored = copy_input(spec, job_dir, self.settings)
            store.create_job(stored.to_dict(), kind=spec.kind, queue=job.kind.queue,
                             job_id=job_id, label=spec.label[:255],
                             total=int(job.kind.steps(job.params)),
                             db_url=self.settings.db_url)
        except Exception:
            shutil.rmtree(job_dir, ignore_errors=True)
            raise
        assert self._pool is not None and self._manager is not None
        queue, cancel = self._manager.Queue(), self._manager.Event()
        live = Live(job_id, cancel)
        live.emit({"type": "queued"})
        with self._lock:
            self._live[job_id] = live
        self._futures[job_id] = self._pool.submit(run_here, self.settings, self.host, job_id,
                                                  stored, queue, cancel)
        threading.Thread(target=_drain, args=(queue, live), name=f"studio-{job_id[:8]}",
                         daemon=True).start()
        return job_id

    # -- following -----------------------------------------------------------------------
    def cancel(self, job_id: str) -> bool:
        """Cancel a queued or running job; ``False`` when it had finished already."""
        live = self._live.get(job_id)
        if live is not None:
            live.cancel.set()
            if live.done.is_set():
                return False
            from inkmotion import store

            record = store.get_job(job_id, self.settings.db_url)
            if record is not None and record.status == "queued":
                store.mark_cancelled(job_id, self.settings.db_url)
            return True
        from inkmotion.workers.submit import cancel_job

        return cancel_job(job_id, self.settings)[0]

    def live(self, job_id: str) -> Live | None:
        return self._live.get(job_id)

    def events(self, job_id: str, index: int = 0) -> tuple[list[dict[str, Any]], int, bool]:
        """The job's events after the first ``index``, the next index, and whether the job
        has ended. A job of this process gives its live events; any other job (queued for
        the workers, or of an earlier studio) one event from its store record."""
        live = self._live.get(job_id)
        if live is not None:
            events = live.since(index)
            return events, index + len(events), live.done.is_set() and not events
        from inkmotion import store

        record = store.get_job(job_id, self.settings.db_url)
        if record is None:
            return [{"type": "end", "status": "missing"}], index + 1, True
        event: dict[str, Any] = {"type": "record", "status": record.status,
                                 "step": record.step, "total": record.total,
                                 "figures": record.losses or {}}
        if record.finished:
            event = {"type": "end", "status": record.status, "error": record.error}
        return [event], index + 1, record.finished

    def close(self) -> None:
        """Cancel what runs here and wait for its processes: a running job stops at its
        next step and leaves no artifacts, a waiting one never starts; both are recorded
        as cancelled."""
        from inkmotion import store

        for live in list(self._live.values()):
            live.cancel.set()
        if self._pool is None:
            return
        self._pool.shutdown(wait=True, cancel_futures=True)
        for job_id, live in list(self._live.items()):
            future = self._futures.get(job_id)
            if future is not None and future.cancelled():  # never started: not left queued
                store.mark_cancelled(job_id, self.settings.db_url)
                live.emit({"type": "end", "status": "cancelled"})
                live.done.set()
            else:
                live.done.wait(5)  # its last events drained
        self._manager.shutdown()


def run_here(settings: Settings, host: str, job_id: str, spec: JobSpec, queue: Any,
             cancel: Any) -> None:
    """Run the recorded job ``job_id`` in this (pool) process under a store lease, its
    events put on ``queue``, stopped at the step after ``cancel`` is set; ends with a
    ``closed`` event."""
    live = _Remote(job_id, queue, cancel)
    from inkmotion import store
    from inkmotion.errors import InkmotionError
    from inkmotion.jobs.checkpoint import remove_checkpoint
    from inkmotion.jobs.shell import run_job
    from inkmotion.workers.leases import Heartbeat, LeaseLost, attempt_owner
    from inkmotion.workers.progress import JobCancelled as StoreCancelled
    from inkmotion.workers.progress import StoreProgressObserver

    db, lease_s = settings.db_url, settings.lease_s
    owner = attempt_owner(host)
    try:
        if live.cancel.is_set() or not store.mark_running(job_id, host, db,
                                                           owner=owner, lease_s=lease_s):
            live.emit({"type": "end", "status": "cancelled"})
            return
        live.emit({"type": "running"})
        artifacts = settings.job_dir(job_id) / "artifacts"
        checkpoint = artifacts.parent / "checkpoint.pt"
        with Heartbeat(job_id, owner, db, lease_s) as beat:
            progress = StoreProgressObserver(job_id, db, owner=owner, lease_s=lease_s,
                                             lost=beat.lost)
            # checkpointed as a worker does: a worker that takes over a dead studio's job
            # resumes it from there
            report = run_job(spec, artifacts, [LiveObserver(live), progress],
                             record=True, recording_id=job_id, checkpoint=checkpoint,
                             checkpoint_every=settings.checkpoint_steps,
                             checkpoint_s=settings.checkpoint_s)
        remove_checkpoint(checkpoint)  # complete: nothing to resume
        store.mark_succeeded(job_id, str(artifacts), db, metrics=report.get("metrics"),
                             owner=owner)
        live.emit({"type": "end", "status": "succeeded"})
    except (JobCancelled, StoreCancelled):
        remove_checkpoint(settings.job_dir(job_id) / "checkpoint.pt")
        store.mark_cancelled(job_id, db)
        live.emit({"type": "end", "status": "cancelled"})
    except LeaseLost:
        live.emit({"type": "end", "status": "failed",
                   "error": "Another process took this job over; see the jobs page."})
    except InkmotionError as exc:
        said = spec.named_by_file(str(exc))  # the upload's name, not the server's folders
        store.mark_failed(job_id, said, db)
        live.emit({"type": "end", "status": "failed", "error": said})
    except Exception as exc:  # noqa: BLE001 - the page gets the failure, the log the trace
        log.exception("studio job %s crashed", job_id)
        message = f"Internal error {type(exc).__name__}: {exc}."
        store.mark_failed(job_id, message, db)
        live.emit({"type": "end", "status": "failed", "error": message})
    finally:
        live.emit({"type": "closed"})


class _Remote:
    """What :class:`LiveObserver` needs of a :class:`Live`, in a pool process."""

    def __init__(self, job_id: str, queue: Any, cancel: Any) -> None:
        self.job_id, self.queue, self.cancel = job_id, queue, cancel

    def emit(self, event: dict[str, Any]) -> None:
        self.queue.put(event)


def _drain(queue: Any, live: Live) -> None:
    """Move a pool process's events into ``live`` until its job closes."""
    while True:
        event = queue.get()
        if event.get("type") == "closed":
            break
        live.emit(event)
    live.done.set()


def _nothing() -> None:
    """A task that makes the pool start a process (and warm it up)."""


def artifacts_of(settings: Settings, job_id: str) -> Path:
    """The artifacts folder of job ``job_id`` (complete only once the job succeeded)."""
    return settings.job_dir(job_id) / "artifacts"
