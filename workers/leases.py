"""Leases kept alive by heartbeats, and the reaper that hands a dead worker's job on.

A running attempt holds its job's lease (``jobs.lease_owner``, ``jobs.lease_until``):
:class:`Heartbeat` renews it every third of the lease from a daemon thread of the worker
process, whatever the job is doing (a long simulation step, a slow CLIP forward), and the
progress updates renew it too. When a worker dies, the renewals stop; every worker runs a
:class:`Reaper` thread that, every ``reaper_interval`` seconds, re-queues the running jobs
whose lease expired (one conditional update per job, so one reaper wins) and sends them
to their queue again. With the defaults (lease 30 s, interval 10 s) a dead worker's job is
queued again at most 40 s after its last heartbeat and starts as soon as a worker is free.

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
import socket
import threading
from typing import Any

log = logging.getLogger("inkmotion.workers")


def attempt_owner(host: str | None = None) -> str:
    """A token naming one attempt: host, process id and a random part."""
    return f"{host or socket.gethostname()}:{os.getpid()}:{secrets.token_hex(4)}"


class LeaseLost(Exception):
    """Raised inside the runner when this attempt no longer holds its job's lease."""


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

    def __init__(self, db_url: str, interval: float) -> None:
        self.db_url, self.interval = db_url, interval
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lease-reaper", daemon=True)

    def start(self) -> Reaper:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()

    def sweep(self) -> list[str]:
        """One look: the ids of the jobs this call re-queued (and sent again)."""
        from inkmotion.store import requeue_expired
        from inkmotion.workers.app import TASK_NAME, app

        sent = []
        for record in requeue_expired(self.db_url):
            app.send_task(TASK_NAME, args=[record.id], queue=record.queue)
            log.warning("job %s: its lease expired (worker %s stopped); queued again on %s",
                        record.id, record.worker_host, record.queue)
            sent.append(record.id)
        return sent

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            try:
                self.sweep()
            except Exception as exc:  # database or broker away: the next look retries
                log.warning("lease reaper: %s: %s", type(exc).__name__, exc)


_REAPER: Reaper | None = None


def start_reaper(**_: Any) -> None:
    """Start this worker process's reaper (Celery's ``worker_ready`` signal)."""
    global _REAPER
    from inkmotion.settings import load_settings

    if _REAPER is None:
        settings = load_settings()
        _REAPER = Reaper(settings.db_url, settings.reaper_interval).start()
