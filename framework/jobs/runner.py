"""Run one job in-process: read, initialise, optimise, write artifacts atomically.

``inkmotion run`` calls :func:`run_job` directly; Celery workers call the same function,
so both write the same artifacts.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from inkmotion.jobs.observers import Observer
from inkmotion.jobs.spec import JobSpec


def run_job(spec: JobSpec, out_dir: str | Path, observers: Sequence[Observer] = (),
            progress: bool = True) -> dict:
    """Execute ``spec`` and place its artifacts in ``out_dir`` atomically; return the report.

    Raises :class:`inkmotion.errors.InkmotionError` subclasses for user-caused failures
    (bad input, unknown plugin); nothing is left in ``out_dir`` then.
    """
    raise NotImplementedError  # filled in by the fitting pipeline
