"""``inkmotion jobs list|show|wait|cancel|logs``: inspect and control queued jobs.

They read the job store (INKMOTION_DB_URL); only ``cancel`` talks to the broker. The store
(SQLAlchemy), Celery and rich's progress bar are imported inside the commands, so
``inkmotion jobs --help`` costs typer and rich alone, and no command here imports torch.
"""

from __future__ import annotations

import json
import sys
import time
from typing import TYPE_CHECKING, Annotated, Any, Optional

import typer
from rich.console import Console
from rich.markup import escape  # a label or an error may hold `[`, rich's markup

from inkmotion.cli.errors import EXIT_TIMEOUT, EXIT_USER, fail, report
from inkmotion.errors import InkmotionError

if TYPE_CHECKING:
    from inkmotion.store import JobRecord

err = Console(stderr=True, emoji=False)  # a label or an error may hold `:x:`: not emoji
out = Console(emoji=False)

STATUS_STYLE = {"queued": "yellow", "running": "cyan", "succeeded": "green", "failed": "red",
                "cancelled": "magenta", "stalled": "red"}
#: the fields ``jobs show`` prints, in this order (empty ones are left out)
SHOWN_FIELDS = ("id", "status", "kind", "queue", "label", "step", "total", "t_end", "losses",
                "metrics", "attempts", "worker_host", "lease_until", "created_at", "started_at",
                "finished_at", "error", "artifact_dir")


def shown_status(r: JobRecord) -> str:
    """The status to show: a running job whose lease expired (its worker stopped renewing
    it) is ``stalled`` until a worker's reaper queues it again, never ``running``."""
    return "stalled" if r.stalled else r.status

jobs_app = typer.Typer(
    help="Inspect and control queued jobs: list, show, wait, cancel, logs.",
    no_args_is_help=True,
)
JobIdArg = Annotated[str, typer.Argument(help="Job id (or a unique prefix).")]
JobIdsArg = Annotated[list[str], typer.Argument(help="Job id(s) (or unique prefixes).")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Machine-readable output.")]


def resolve_job(job_id: str) -> JobRecord:
    """The job record for a full id or a unique prefix, or exit with one sentence."""
    from inkmotion.store import find_job
    from inkmotion.store.records import MIN_PREFIX

    found = find_job(job_id)
    if found is None and len(job_id) < MIN_PREFIX:
        fail(f"{job_id!r} is too short to name a job: give at least {MIN_PREFIX} characters "
             "of its id (`inkmotion jobs list` shows them).")
    if found is None:
        fail(f"No job {job_id!r} in the job store; `inkmotion jobs list` shows the jobs.")
    if isinstance(found, list):
        fail(f"{job_id!r} matches {len(found)} jobs; give more characters of the id.")
    return found


def _age(record: JobRecord) -> str:
    """How long ago the job was created, in the coarsest unit that is still telling."""
    from datetime import datetime, timezone

    created = record.created_at
    s = (datetime.now(timezone.utc) - created).total_seconds()
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h" if s < 172800 else created.strftime("%Y-%m-%d")


def _figures(values: dict[str, Any]) -> str:
    """``name=value, ...`` with 4 significant digits for floats (losses, metrics); counts and
    text print as they are."""
    return ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                     for k, v in values.items())


@jobs_app.command("list")
def jobs_list(
    status: Annotated[Optional[list[str]], typer.Option(  # noqa: UP045 - typer needs Optional
        "--status", help="Only jobs with this status (repeatable).")] = None,
    limit: Annotated[int, typer.Option(help="At most this many, newest first.")] = 50,
    as_json: JsonOpt = False,
) -> None:
    """List jobs, newest first."""
    from inkmotion.store import list_jobs

    try:
        records = list_jobs(status or None, limit=limit)
    except InkmotionError as exc:
        fail(exc)
    if as_json:
        print(json.dumps([r.to_dict() for r in records], indent=1))
        return
    if not records:
        err.print("no jobs" + (f" with status {', '.join(status)}" if status else "")
                  + "; `inkmotion submit` queues one.", highlight=False)
        return
    out.print(jobs_table(records, out.width))


def jobs_table(records: list[JobRecord], width: int) -> Any:
    """The table of ``jobs list`` for a console ``width`` columns wide: short figures never
    wrap; the id (a copyable prefix) never shrinks, the input folds rather than lose
    characters to an ellipsis; the worker is left to ``jobs show`` below 100 columns,
    where it would squeeze the input."""
    from rich.table import Table

    table = Table(box=None, pad_edge=False, header_style="bold underline")
    for name in ("id", "status", "kind", "steps", "tries", "age"):
        table.add_column(name, no_wrap=True)
    table.add_column("input", overflow="fold")
    workers = width >= 100
    if workers:
        table.add_column("worker", overflow="fold")
    for r in records:
        status = shown_status(r)
        style = STATUS_STYLE.get(status, "")
        steps = f"{r.step}/{r.total}" if r.total else ""
        row = [r.id[:12], f"[{style}]{status}[/]", r.kind, steps, str(r.attempts), _age(r),
               escape(r.label)]
        table.add_row(*row, *([escape(r.worker_host or "")] if workers else []))
    return table


@jobs_app.command("show")
def jobs_show(job_id: JobIdArg, as_json: JsonOpt = False) -> None:
    """Show one job: status, progress, losses, metrics, attempts, errors, artifacts."""
    record = resolve_job(job_id)
    d = record.to_dict()
    d["status"] = shown_status(record)
    if as_json:
        print(json.dumps(d, indent=1))
        return
    shown = [k for k in SHOWN_FIELDS if d.get(k) not in (None, "", {})]  # `metrics` is
    width = max(map(len, shown))  # absent from records of older stores
    for key in shown:
        value = _figures(d[key]) if key in ("losses", "metrics") else str(d[key])
        # one line each, wrapped by the terminal: an id or a path stays whole to copy
        out.print(f"[bold]{key:<{width}}[/]  {escape(value)}", soft_wrap=True,
                  highlight=False)


def _finished_line(r: JobRecord) -> str:
    style = STATUS_STYLE.get(r.status, "")
    line = f"{r.id}: [{style}]{r.status}[/]"
    if r.status == "succeeded":
        line += f" -> {escape(r.artifact_dir or '')}"
    elif r.error:
        line += f": {escape(r.error)}"
    return line


def _progress_info(r: JobRecord) -> str:
    info = r.status
    if r.losses:
        info += f"  loss {r.losses.get('total', 0.0):.4g}"
    if r.t_end is not None:
        info += f"  T_end/path {r.t_end:.3g}"  # the mean over paths (the progress's)
    return info


@jobs_app.command("wait")
def jobs_wait(
    job_ids: JobIdsArg,
    timeout: Annotated[Optional[float], typer.Option(  # noqa: UP045
        help="Give up after this many seconds (exit code 3).")] = None,
    interval: Annotated[float, typer.Option(help="Polling interval, s.")] = 0.5,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress display.")] = False,
) -> None:
    """Wait for jobs to finish; exit 0 only when all succeeded (1 otherwise, 3 on timeout)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    from inkmotion.store import get_job

    ids = [resolve_job(j).id for j in job_ids]
    deadline = None if timeout is None else time.monotonic() + timeout
    done: dict[str, JobRecord] = {}
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("{task.fields[info]}"))
    with Progress(*columns, console=err, disable=quiet, transient=False) as bar:
        tasks = {i: bar.add_task(i[:12], total=None, info="") for i in ids}
        while len(done) < len(ids):
            for i in ids:
                if i in done:
                    continue
                r = get_job(i)
                if r is None:
                    fail(f"Job {i} disappeared from the job store.")
                bar.update(tasks[i], total=r.total or None, completed=r.step,
                           info=_progress_info(r))
                if r.finished:
                    done[i] = r
            if len(done) == len(ids):
                break
            if deadline is not None and time.monotonic() > deadline:
                bar.stop()
                pending = [i for i in ids if i not in done]
                fail(f"Timed out after {timeout:g} s; still unfinished: "
                     f"{', '.join(p[:12] for p in pending)}.", code=EXIT_TIMEOUT)
            time.sleep(interval)
    for i in ids:
        err.print(_finished_line(done[i]), highlight=False, soft_wrap=True)
    unsuccessful = [r for r in done.values() if r.status != "succeeded"]
    if unsuccessful:
        fail(f"{len(unsuccessful)} of {len(ids)} job(s) did not succeed "
             f"({', '.join(f'{r.id[:12]} {r.status}' for r in unsuccessful)}); "
             "`inkmotion jobs logs ID` shows why.")


@jobs_app.command("cancel")
def jobs_cancel(job_ids: JobIdsArg) -> None:
    """Cancel queued or running jobs (revoke with terminate, and mark cancelled)."""
    from inkmotion.workers.submit import cancel_job

    code = 0
    for j in job_ids:
        r = resolve_job(j)
        cancelled, warning = cancel_job(r.id)
        if cancelled:
            err.print(f"{r.id}: cancelled", highlight=False)
        else:
            report(f"{r.id} is already {r.status}; nothing to cancel.")
            code = EXIT_USER
        if warning:
            err.print(f"[yellow]warning:[/] {warning}", highlight=False)
    raise typer.Exit(code)


@jobs_app.command("logs")
def jobs_logs(job_id: JobIdArg) -> None:
    """Print a job's log (attempts, hosts, errors with tracebacks)."""
    from inkmotion.settings import load_settings

    r = resolve_job(job_id)
    log = load_settings().job_dir(r.id) / "job.log"
    if log.is_file():
        sys.stdout.write(log.read_text(encoding="utf-8", errors="replace"))
    else:
        err.print(f"{r.id}: no log yet (status {r.status}).", highlight=False)
    if r.error:
        report(r.error)


def register(app: typer.Typer) -> None:
    """Add the ``jobs`` group to the ``inkmotion`` app."""
    app.add_typer(jobs_app, name="jobs")
