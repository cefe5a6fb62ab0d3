"""Leases kept alive by heartbeats, and the reaper that hands a dead worker's job on.

A running attempt holds its job's lease (``jobs.lease_owner``, ``jobs.lease_until``):
:class:`Heartbeat` renews it every third of the lease from a daemon thread of the worker
process, whatever the job is doing (a long simulation step, a slow CLIP forward), and the
progress updates renew it too. When a worker dies, the renewals stop; every worker runs a
:class:`Reaper` thread that, every ``reaper_interval`` seconds, re-queues the running jobs
whose lease expired (one conditional update per job, so one reaper wins) and sends them
to their queue again. With the defaults (lease 30 s, interval 10 s) a dead worker's job is
queued again at most 40 s after its last heartbeat and starts as soon as a worker is free.
When the broker is away (Redis down for longer than a lease: the running task is ended
by Celery, its lease then expires), a job whose message cannot be sent is put back as
the reaper found it, and a later look, once the broker is back, sends it. A worker that
has had nothing to do for ``INKMOTION_STRANDED_S`` (120 s) also sends again the jobs of
its queues that stayed queued all that time: their message is lost (Redis emptied, or a
worker pointed at another job store took it and dropped it).

The broker's own redelivery (the unacknowledged message, after the visibility timeout)
is kept as a backstop: when it comes, the job has finished and is skipped, so the
visibility timeout no longer has to exceed the longest job. An attempt that loses its
lease (cut off from the database longer than the lease, then re-queued elsewhere) learns
it at its next heartbeat or progress write and stops without writing a result.
"""

from __future__ import annotations

import logging
import os
import secrets
import signal
import socket
import threading
from datetime import timedelta
from typing import Any

log = logging.getLogger("inkmotion.workers")


def attempt_owner(host: str | None = None) -> str:
    """A token naming one attempt: host, process id and a random part."""
    return f"{host or socket.gethostname()}:{os.getpid()}:{secrets.token_hex(4)}"


class LeaseLost(Exception):
    """Raised inside the runner when this attempt no longer holds its job's lease."""


class HandBack(Exception):
    """Raised inside the runner when the worker is shutting down: the job, checkpointed,
    goes back to its queue for another worker."""


#: set when this worker process was asked to shut down (SIGTERM: a redeploy, autoscaling)
SHUTDOWN = threading.Event()
#: seconds a shutting-down worker waits for its job to hand itself back before it exits
SHUTDOWN_GRACE_S = 30.0


def on_worker_shutting_down(**_: Any) -> None:
    """Celery's ``worker_shutting_down`` (the first SIGTERM): ask the running job to
    checkpoint and hand itself back at its next step; if it has not within the grace
    time (``INKMOTION_SHUTDOWN_GRACE_S``), end the process anyway (its lease then expires
    and a reaper re-queues it). A second SIGTERM is Celery's cold shutdown."""
    if SHUTDOWN.is_set():
        return
    SHUTDOWN.set()  # the solo pool runs the job in this process
    try:  # a prefork pool runs it in a child: tell each child (see install_child_handler)
        import billiard.process

        for child in billiard.process.active_children():
            os.kill(child.pid, signal.SIGUSR2)
    except (ImportError, OSError) as exc:
        log.warning("worker: could not tell the pool's processes to hand back (%s)", exc)
    grace = float(os.environ.get("INKMOTION_SHUTDOWN_GRACE_S", SHUTDOWN_GRACE_S))

    def give_up() -> None:
        log.warning("worker: the running job did not hand itself back within %.0f s; "
                    "exiting (its lease will expire and another worker takes it)", grace)
        logging.shutdown()
        os._exit(1)

    timer = threading.Timer(grace, give_up)
    timer.daemon = True
    timer.start()


class Heartbeat:
    """Renews ``owner``'s lease on ``job_id`` every ``lease_s / 3`` seconds in a daemon
    thread; :attr:`lost` is set once a renewal finds the job no longer ours."""

    def __init__(self, job_id: str, owner: str, db_url: str, lease_s: float) -> None:
        self.job_id, self.owner, self.db_url, self.lease_s = job_id, owner, db_url, lease_s
        self.lost = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._beat, name=f"lease-{job_id[:8]}",
                                        daemon=True)

    def __enter__(self) -> Heartbeat:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5)

    def _beat(self) -> None:
        from sqlalchemy.exc import SQLAlchemyError

        from inkmotion.store import renew_lease

        while not self._stop.wait(self.lease_s / 3):
            try:
                if not renew_lease(self.job_id, self.owner, self.db_url, self.lease_s):
                    self.lost.set()
                    return
            except SQLAlchemyError as exc:  # the database is briefly away: try again
                log.warning("job %s: lease not renewed (%s)", self.job_id, exc)


class Reaper:
    """Every ``interval`` seconds, re-queue the jobs whose lease expired and send them to
    their queue (module docstring). One per worker process, a daemon thread."""

    def __init__(self, db_url: str, interval: float, stranded_s: float = 0.0,
                 queues: tuple[str, ...] = ()) -> None:
        self.db_url, self.interval = db_url, interval
        self.stranded_s, self.queues = stranded_s, queues
        self._idle_since: Any = None  # a UTC datetime while this worker has nothing to do
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lease-reaper", daemon=True)

    def start(self) -> Reaper:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()

    def sweep(self) -> list[str]:
        """One look: the ids of the jobs this call re-queued (and sent again)."""
        from inkmotion.store import requeue_expired, unsent
        from inkmotion.workers.app import TASK_NAME, app

        sent: list[str] = []
        records = requeue_expired(self.db_url)
        for record in records:
            try:
                app.send_task(TASK_NAME, args=[record.id], queue=record.queue)
            except Exception:  # the broker is away: these go back as they were, for the
                for left in records[len(sent):]:  # next look to send (module docstring)
                    unsent(left.id, self.db_url)
                raise
            log.warning("job %s: its lease expired (worker %s stopped); queued again on %s",
                        record.id, record.worker_host, record.queue)
            sent.append(record.id)
        return sent + self.resend_stranded()

    def resend_stranded(self) -> list[str]:
        """Send again the jobs of this worker's queues that stayed queued for the last
        ``stranded_s`` seconds while this worker had nothing to do: their message is lost
        (Redis emptied, or taken by a worker with another job store, which dropped it),
        and the store is what says they are wanted. A duplicate of a message still on its
        way finds the job running or done and does nothing."""
        from inkmotion.store import claim_stranded, unclaim
        from inkmotion.store.records import utcnow
        from inkmotion.workers.app import TASK_NAME, app

        if not self.stranded_s or not self.queues:
            return []
        now = utcnow()
        if _busy():
            self._idle_since = None
            return []
        if self._idle_since is None:
            self._idle_since = now
        if (now - self._idle_since).total_seconds() < self.stranded_s:
            return []
        sent: list[str] = []  # queued over stranded_s ago, idle all that time: lost
        claimed = claim_stranded(self.queues, now - timedelta(seconds=self.stranded_s),
                                 self.db_url)
        for record, _ in claimed:
            try:
                app.send_task(TASK_NAME, args=[record.id], queue=record.queue)
            except Exception:  # the broker is away: a later look takes them again
                for left, when in claimed[len(sent):]:
                    unclaim(left.id, when, self.db_url)
                raise
            log.warning("job %s: queued for over %.0f s while this worker was idle, its "
                        "message lost; sent again on %s", record.id, self.stranded_s,
                        record.queue)
            sent.append(record.id)
        return sent

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            try:
                self.sweep()
            except Exception as exc:  # database or broker away: the next look retries
                log.warning("lease reaper: %s: %s", type(exc).__name__, exc)


def _busy() -> bool:
    """Whether this worker holds a task (running, or received and waiting its turn)."""
    from celery.worker import state

    return bool(state.active_requests or state.reserved_requests)


def install_child_handler(**_: Any) -> None:
    """Celery's ``worker_process_init`` (a prefork pool process starts): SIGUSR2 from the
    shutting-down main process sets :data:`SHUTDOWN` here too."""
    signal.signal(signal.SIGUSR2, lambda *_: SHUTDOWN.set())


_REAPER: Reaper | None = None


def start_reaper(sender: Any = None, **_: Any) -> None:
    """Start this worker process's reaper (Celery's ``worker_ready`` signal, whose sender
    is the consumer: its queues are those whose stranded jobs the reaper sends again)."""
    global _REAPER
    from inkmotion.settings import load_settings

    if _REAPER is None:
        settings = load_settings()
        consumer = getattr(sender, "task_consumer", None)
        queues = tuple(q.name for q in getattr(consumer, "queues", None) or ())
        _REAPER = Reaper(settings.db_url, settings.reaper_interval, settings.stranded_s,
                         queues).start()
