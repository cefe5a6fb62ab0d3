"""Observer that writes a running job's progress into the job store."""

from __future__ import annotations

import logging
import threading
import time

from inkmotion.events import StepState

log = logging.getLogger("inkmotion.workers")


class JobCancelled(Exception):
    """Raised inside the runner when the job was cancelled while running."""


class StoreProgressObserver:
    """Writes step/total, loss terms and T_end at most every ``min_interval`` seconds
    (and on the last step), renewing ``owner``'s lease with each write; stops the run with
    :class:`JobCancelled` when the record is no longer ``running`` (``inkmotion jobs
    cancel`` on a worker that cannot be signalled), and with
    :class:`~inkmotion.workers.leases.LeaseLost` when the attempt lost its lease (``lost``
    set by its heartbeat, or a write that finds another owner), and with
    :class:`~inkmotion.workers.leases.HandBack` one step after ``shutdown`` is set (the
    worker is shutting down; a checkpointing job kind wrote its checkpoint at that step).
    A database hiccup while writing progress is logged, not fatal."""

    def __init__(self, job_id: str, db_url: str | None = None,
                 min_interval: float = 0.5, *, owner: str | None = None,
                 lease_s: float = 30.0, lost: threading.Event | None = None,
                 shutdown: threading.Event | None = None) -> None:
        self.job_id = job_id
        self.db_url = db_url
        self.min_interval = min_interval
        self.owner, self.lease_s, self.lost, self.shutdown = owner, lease_s, lost, shutdown
        self._last = 0.0
        self._shutdown_seen = False

    def _stopped_by(self) -> Exception | None:
        """Why this attempt must stop, read from the job's record: JobCancelled when it
        was cancelled (or is gone), LeaseLost when another attempt owns it, else None."""
        from inkmotion.store import get_job
        from inkmotion.workers.leases import LeaseLost

        record = get_job(self.job_id, self.db_url)
        if record is None or record.status == "cancelled":
            return JobCancelled(self.job_id)
        if self.owner is not None and record.lease_owner != self.owner:
            return LeaseLost(self.job_id)
        return None

    def on_step(self, state: StepState) -> None:
        from sqlalchemy.exc import SQLAlchemyError

        from inkmotion.store import update_progress
        from inkmotion.workers.leases import HandBack, LeaseLost

        if self.lost is not None and self.lost.is_set():
            # the heartbeat's renewal fails for a cancel too: tell the two apart (one read)
            try:
                reason = self._stopped_by()
            except SQLAlchemyError:
                reason = None
            raise reason or LeaseLost(self.job_id)
        if self.shutdown is not None and self.shutdown.is_set():
            if self._shutdown_seen:  # the step before checkpointed (when the kind does)
                raise HandBack(self.job_id)
            self._shutdown_seen = True
        now = time.monotonic()
        if now - self._last < self.min_interval and state.step != state.total:
            return
        self._last = now
        try:
            values = state.loss_values()  # one device read, every min_interval seconds
            ok = update_progress(self.job_id, state.step, state.total, values,
                                 None if state.t_end is None else float(state.t_end),
                                 db_url=self.db_url, owner=self.owner,
                                 lease_s=self.lease_s)
            if not ok and (reason := self._stopped_by()) is not None:
                raise reason
        except SQLAlchemyError as exc:
            log.warning("job %s: progress not recorded (%s)", self.job_id, exc)
