"""Commands of the distributed path: submit, jobs, worker, view.

``register(app)`` adds them to the ``inkmotion`` typer app. They talk to the job store
(INKMOTION_DB_URL) and the broker (INKMOTION_BROKER_URL); ``inkmotion run`` needs neither.
User errors are one sentence on stderr and exit code 1, never a traceback.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, NoReturn, Optional

import typer
from rich.console import Console
from rich.table import Table

from inkmotion.errors import InkmotionError, SpecError

if TYPE_CHECKING:
    from inkmotion.store import JobRecord

err = Console(stderr=True)
out = Console()
EXIT_TIMEOUT = 3  # `jobs wait` ran out of time

jobs_app = typer.Typer(
    help="Inspect and control queued jobs: list, show, wait, cancel, logs.",
    no_args_is_help=True,
)


def _fail(exc: BaseException | str, code: int = 1) -> NoReturn:
    err.print(f"[bold red]error:[/] {exc}", highlight=False)
    raise typer.Exit(code)


def _resolve(job_id: str) -> JobRecord:
    """The job record for a full id or a unique prefix, or exit with one sentence."""
    from inkmotion.store import find_job

    found = find_job(job_id)
    if found is None:
        _fail(f"No job {job_id!r} in the job store; `inkmotion jobs list` shows the jobs.")
    if isinstance(found, list):
        _fail(f"{job_id!r} matches {len(found)} jobs; give more characters of the id.")
    return found


# -- jobs --------------------------------------------------------------------------------

def _age(record: JobRecord) -> str:
    from datetime import datetime, timezone

    created = record.created_at
    s = (datetime.now(timezone.utc) - created).total_seconds()
    if s < 90:
        return f"{s:.0f} s ago"
    if s < 5400:
        return f"{s / 60:.0f} min ago"
    return f"{s / 3600:.1f} h ago" if s < 172800 else created.strftime("%Y-%m-%d")


STATUS_STYLE = {"queued": "yellow", "running": "cyan", "succeeded": "green", "failed": "red",
                "cancelled": "magenta"}


@jobs_app.command("list")
def jobs_list(
    status: Annotated[Optional[list[str]], typer.Option(  # noqa: UP045
        "--status", help="Only jobs with this status (repeatable).")] = None,
    limit: Annotated[int, typer.Option(help="At most this many, newest first.")] = 50,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """List jobs, newest first."""
    from inkmotion.store import list_jobs

    try:
        records = list_jobs(status or None, limit=limit)
    except InkmotionError as exc:
        _fail(exc)
    if as_json:
        print(json.dumps([r.to_dict() for r in records], indent=1))
        return
    table = Table("id", "status", "kind", "input", "progress", "attempts", "worker", "created")
    for column in table.columns[:2]:
        column.no_wrap = True
    for r in records:
        style = STATUS_STYLE.get(r.status, "")
        progress = f"{r.step}/{r.total}" if r.total else ""
        table.add_row(r.id[:12], f"[{style}]{r.status}[/]", r.kind, r.label, progress,
                      str(r.attempts), r.worker_host or "", _age(r))
    out.print(table)


@jobs_app.command("show")
def jobs_show(
    job_id: Annotated[str, typer.Argument(help="Job id (or a unique prefix).")],
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Show one job: status, progress, losses, attempts, errors, artifacts."""
    r = _resolve(job_id)
    d = r.to_dict()
    if as_json:
        print(json.dumps(d, indent=1))
        return
    table = Table(show_header=False, box=None)
    for key in ("id", "status", "kind", "queue", "label", "step", "total", "t_end", "losses",
                "metrics", "attempts", "worker_host", "created_at", "started_at",
                "finished_at", "error", "artifact_dir"):
        value = d.get(key)
        if value is None or value == "":
            continue
        if key in ("losses", "metrics"):
            value = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                              for k, v in value.items())
        table.add_row(f"[bold]{key}[/]", str(value))
    out.print(table)


def _finished_line(r: JobRecord) -> str:
    status = r.status
    style = STATUS_STYLE.get(status, "")
    line = f"{r.id}: [{style}]{status}[/]"
    if status == "succeeded":
        line += f" -> {r.artifact_dir}"
    elif r.error:
        line += f": {r.error}"
    return line


@jobs_app.command("wait")
def jobs_wait(
    job_ids: Annotated[list[str], typer.Argument(help="Job id(s) (or unique prefixes).")],
    timeout: Annotated[Optional[float], typer.Option(  # noqa: UP045
        help="Give up after this many seconds (exit code 3).")] = None,
    interval: Annotated[float, typer.Option(help="Polling interval, s.")] = 0.5,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress display.")] = False,
) -> None:
    """Wait for jobs to finish; exit 0 only when all succeeded (1 otherwise, 3 on timeout)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    from inkmotion.store import get_job

    ids = [_resolve(j).id for j in job_ids]
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
                    _fail(f"Job {i} disappeared from the job store.")
                info = r.status
                if r.losses:
                    info += f"  loss {r.losses.get('total', 0.0):.4g}"
                if r.t_end is not None:
                    info += f"  T_end {r.t_end:.3g}"
                bar.update(tasks[i], total=r.total or None, completed=r.step, info=info)
                if r.finished:
                    done[i] = r
            if len(done) == len(ids):
                break
            if deadline is not None and time.monotonic() > deadline:
                bar.stop()
                pending = [i for i in ids if i not in done]
                _fail(f"Timed out after {timeout:g} s; still unfinished: "
                      f"{', '.join(p[:12] for p in pending)}.", code=EXIT_TIMEOUT)
            time.sleep(interval)
    for i in ids:
        err.print(_finished_line(done[i]), highlight=False)
    if any(r.status != "succeeded" for r in done.values()):
        raise typer.Exit(1)


@jobs_app.command("cancel")
def jobs_cancel(
    job_ids: Annotated[list[str], typer.Argument(help="Job id(s) (or unique prefixes).")],
) -> None:
    """Cancel queued or running jobs (revoke with terminate, and mark cancelled)."""
    from inkmotion.workers.submit import cancel_job

    code = 0
    for j in job_ids:
        r = _resolve(j)
        cancelled, warning = cancel_job(r.id)
        if cancelled:
            err.print(f"{r.id}: cancelled", highlight=False)
        else:
            err.print(f"{r.id}: already {r.status}; nothing to cancel",
                      highlight=False)
            code = 1
        if warning:
            err.print(f"[yellow]warning:[/] {warning}", highlight=False)
    raise typer.Exit(code)


@jobs_app.command("logs")
def jobs_logs(
    job_id: Annotated[str, typer.Argument(help="Job id (or a unique prefix).")],
) -> None:
    """Print a job's log (attempts, hosts, errors with tracebacks)."""
    from inkmotion.settings import load_settings

    r = _resolve(job_id)
    log = load_settings().job_dir(r.id) / "job.log"
    if log.is_file():
        sys.stdout.write(log.read_text(encoding="utf-8", errors="replace"))
    else:
        err.print(f"{r.id}: no log yet (status {r.status}).", highlight=False)
    if r.error:
        err.print(f"[bold red]error:[/] {r.error}", highlight=False)


# -- worker ------------------------------------------------------------------------------

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
    hostname: Annotated[Optional[str], typer.Option(  # noqa: UP045
        "--hostname", "-n", help="Worker node name, e.g. gpu1@%h.")] = None,
) -> None:
    """Start a Celery worker for queued jobs (stop it with Ctrl-C: jobs in hand requeue).

    Examples: `inkmotion worker` (CPU, every queue); on a GPU machine
    `inkmotion worker -Q optimise -c 1`.
    """
    from inkmotion.settings import load_settings
    from inkmotion.store import get_engine
    from inkmotion.workers.app import app, known_queues
    from inkmotion.workers.submit import check_broker

    queues_known = known_queues()
    wanted = [q.strip() for q in queues.split(",") if q.strip()] or list(queues_known)
    unknown = sorted(set(wanted) - set(queues_known))
    if unknown or not wanted:
        _fail(f"Unknown queue(s) {', '.join(unknown) or '(none)'}; queues are "
              f"{', '.join(queues_known)}.", code=2)
    if concurrency < 1:
        _fail("--concurrency must be at least 1.", code=2)
    try:
        settings = load_settings()
        check_broker(settings)
        get_engine(settings.db_url)  # create or upgrade the schema once, before forking
    except InkmotionError as exc:
        _fail(exc)
    argv = ["worker", f"--queues={','.join(wanted)}", f"--concurrency={concurrency}",
            f"--loglevel={loglevel}", f"--pool={pool}"]
    if hostname:
        argv.append(f"--hostname={hostname}")
    app.worker_main(argv)


# -- view --------------------------------------------------------------------------------

def _rerun_binary() -> str | None:
    here = Path(sys.executable).parent / "rerun"
    return str(here) if here.is_file() else shutil.which("rerun")


def has_display() -> bool:
    """True where a viewer window can open (X11/Wayland, or macOS/Windows)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def recording_path(target: str) -> Path:
    """The .rrd for ``target``: a file path, or a job id whose artifacts hold one."""
    from inkmotion.recording import RECORDING_NAME

    p = Path(target)
    if p.suffix == ".rrd" or p.is_file():
        if not p.is_file():
            raise SpecError(f"{p}: no such recording file; check the path.")
        return p.resolve()
    if p.is_dir() and (p / RECORDING_NAME).is_file():
        return (p / RECORDING_NAME).resolve()
    r = _resolve(target)
    if r.status != "succeeded" or not r.artifact_dir:
        raise SpecError(f"Job {r.id} is {r.status}; its recording appears when it "
                        "has succeeded (`inkmotion jobs wait` waits for it).")
    rrd = Path(r.artifact_dir) / RECORDING_NAME
    if not rrd.is_file():
        raise SpecError(f"Job {r.id} has no {RECORDING_NAME} in {r.artifact_dir}.")
    return rrd


def view_cmd(
    target: Annotated[str, typer.Argument(help="Job id, results folder or FILE.rrd.")],
    print_only: Annotated[bool, typer.Option(
        "--print", help="Only print the command that opens the viewer.")] = False,
) -> None:
    """Open a job's rerun recording in the viewer (or print the command to run)."""
    try:
        rrd = recording_path(target)
    except InkmotionError as exc:
        _fail(exc)
    binary = _rerun_binary()
    command = f"{binary or 'rerun'} {rrd}"
    if print_only or not has_display() or binary is None:
        why = "" if print_only else ("no display here; " if binary else
                                     "the rerun viewer is not installed here; ")
        out.print(f"{why}open the recording with:\n  {command}\n"
                  f"or in a browser: {binary or 'rerun'} --web-viewer {rrd}", highlight=False,
                  soft_wrap=True)
        return
    subprocess.Popen([binary, str(rrd)], start_new_session=True,
                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out.print(f"opened {rrd} in the rerun viewer", highlight=False)


def register(app: typer.Typer) -> None:
    """Add jobs, worker and view to the ``inkmotion`` app."""
    app.add_typer(jobs_app, name="jobs")
    app.command("worker")(worker_cmd)
    app.command("view")(view_cmd)
