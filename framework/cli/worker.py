"""``inkmotion worker``: start a Celery worker that runs queued jobs.

Celery, the job kinds and the job store are imported only when the command runs (a worker
start takes seconds anyway); importing this module costs typer alone.
"""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from inkmotion.cli.errors import EXIT_USAGE, fail
from inkmotion.errors import InkmotionError


def worker_cmd(
    queues: Annotated[str, typer.Option(
        "--queues", "-Q", help="Comma-separated queues, e.g. optimise (GPU-friendly), "
        "simulate, or those of third-party job kinds; default: every known queue.")
    ] = "",
    concurrency: Annotated[int, typer.Option(
        "--concurrency", "-c", help="Jobs at once (processes).")] = 1,
    loglevel: Annotated[str, typer.Option("--loglevel", "-l", help="Celery log level.")] =
    "info",
    pool: Annotated[str, typer.Option(help="Celery pool: prefork or solo.")] = "prefork",
    batch: Annotated[int, typer.Option(
        "--batch", "-b", min=1, help="Fit jobs a slot takes from its queue at once and "
        "optimises as one batch when they are compatible (same parameters).")] = 1,
    hostname: Annotated[Optional[str], typer.Option(  # noqa: UP045 - typer needs Optional
        "--hostname", "-n", help="Worker node name, e.g. gpu1@%h.")] = None,
) -> None:
    """Start a Celery worker for queued jobs (stop it with Ctrl-C: jobs in hand requeue).

    Examples: `inkmotion worker` (CPU, every queue); on a GPU machine
    `inkmotion worker -Q optimise -c 1 --batch 16` (up to 16 fits in one optimisation).
    """
    from inkmotion.settings import load_settings
    from inkmotion.store import get_engine
    from inkmotion.workers.app import app, known_queues
    from inkmotion.workers.submit import check_broker

    queues_known = known_queues()
    wanted = [q.strip() for q in queues.split(",") if q.strip()] or list(queues_known)
    unknown = sorted(set(wanted) - set(queues_known))
    if unknown or not wanted:
        fail(f"Unknown queue(s) {', '.join(unknown) or '(none)'}; queues are "
             f"{', '.join(queues_known)}.", code=EXIT_USAGE)
    if concurrency < 1:
        fail("--concurrency must be at least 1.", code=EXIT_USAGE)
    try:
        settings = load_settings()
        check_broker(settings)
        get_engine(settings.db_url)  # create or upgrade the schema once, before forking
    except InkmotionError as exc:
        fail(exc)
    import os

    from inkmotion.devices import available_cores, default_threads
    from inkmotion.workers.tasks import BATCH_ENV

    slots = 1 if pool == "solo" else concurrency
    if batch != 1:
        os.environ[BATCH_ENV] = str(batch)
    batch = int(os.environ.get(BATCH_ENV, batch) or 1)
    typer.echo(f"inkmotion worker: {slots} job slot(s) on {available_cores()} core(s); each "
               f"job runs with the threads of its spec (default {default_threads()})"
               + (f", up to {batch} fit jobs per batch" if batch > 1 else ""))
    argv = ["worker", f"--queues={','.join(wanted)}", f"--concurrency={concurrency}",
            f"--loglevel={loglevel}", f"--pool={pool}"]
    if hostname:
        argv.append(f"--hostname={hostname}")
    app.worker_main(argv)


def register(app: typer.Typer) -> None:
    """Add ``worker`` to the ``inkmotion`` app."""
    app.command("worker")(worker_cmd)
