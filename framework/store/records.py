"""What a job-store row is, without SQLAlchemy: the statuses and the :class:`JobRecord`
snapshot that every query returns.

Kept apart from the models and the queries so that the read-only commands of the command
line (``jobs list``, ``jobs show``, ``view``) can build records through
:mod:`inkmotion.store.reads` without importing SQLAlchemy (about 0.15 s of start-up).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from datetime import datetime, timezone
from typing import Any

STATUSES = ("queued", "running", "succeeded", "failed", "cancelled")
FINAL_STATUSES = ("succeeded", "failed", "cancelled")


def utcnow() -> datetime:
    """Now, timezone-aware in UTC (every timestamp of the store is)."""
    return datetime.now(timezone.utc)


#: the fewest characters of a job id that are looked up as its prefix
MIN_PREFIX = 4


@dataclass(frozen=True)
class JobRecord:
    """A snapshot of one job row.

    ``metrics`` holds the job kind's summary figures once it succeeded (``None`` before,
    and for jobs recorded before revision 0002); it comes last with a default so that
    code building records by keyword keeps working."""

    id: str
    kind: str
    queue: str
    status: str
    spec: dict[str, Any]
    label: str
    step: int
    total: int
    losses: dict[str, float] | None
    t_end: float | None
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
    updated_at: datetime
    worker_host: str | None
    attempts: int
    error: str | None
    artifact_dir: str | None
    metrics: dict[str, Any] | None = None
    lease_owner: str | None = None
    lease_until: datetime | None = None

    @property
    def finished(self) -> bool:
        return self.status in FINAL_STATUSES

    @property
    def stalled(self) -> bool:
        """Running, but its lease has expired: its worker stopped renewing it (died or was
        cut off), and a reaper will put it back on the queue."""
        return (self.status == "running" and self.lease_until is not None
                and self.lease_until < utcnow())

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict of every field, ``metrics`` included (ISO 8601 timestamps)."""
        d = asdict(self)
        for k, v in d.items():
            if isinstance(v, datetime):
                d[k] = v.isoformat()
        return d


def check_statuses(status: str | Any) -> list[str]:
    """``status`` (one or several) as a list, each a known status, else one sentence."""
    statuses = [status] if isinstance(status, str) else list(status)
    unknown = set(statuses) - set(STATUSES)
    if unknown:
        from inkmotion.errors import SpecError

        raise SpecError(f"Unknown status {', '.join(sorted(unknown))}; "
                        f"statuses are {', '.join(STATUSES)}.")
    return statuses
