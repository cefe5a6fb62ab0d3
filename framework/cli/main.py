"""The ``inkmotion`` command line (typer).

One module per command group: :mod:`~inkmotion.cli.run`, :mod:`~inkmotion.cli.submit`,
:mod:`~inkmotion.cli.jobs`, :mod:`~inkmotion.cli.worker`, :mod:`~inkmotion.cli.view` and
:mod:`~inkmotion.cli.gallery`,
each with a ``register(app)``; ``plugins`` and ``bench`` live here. Start-up matters (every
command pays it): modules on this path import typer, rich, the standard library and light
project modules (errors, job specs) only; torch, NumPy, the job store, Celery and rerun are
imported inside the commands that use them (``tests/test_cli_startup.py`` checks this).
Errors are reported by :mod:`inkmotion.cli.errors`.
"""

from __future__ import annotations

import json
import os
import sys
import warnings
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from inkmotion.cli import (
    benchmark,
    clip,
    evaluate,
    gallery,
    interrupts,
    jobs,
    render,
    robot,
    run,
    samples,
    studio,
    submit,
    trace,
    view,
    worker,
)
from inkmotion.cli.errors import EXIT_USER, fail, report
from inkmotion.errors import InkmotionError

try:  # typer vendors click from 0.2x on; its usage errors derive from TyperException
    from typer import Abort
    from typer import TyperException as UsageProblem
except ImportError:  # an older typer, on click itself
    from click import Abort  # type: ignore[assignment]
    from click import ClickException as UsageProblem  # type: ignore[assignment]

app = typer.Typer(
    name="inkmotion",
    help="Turn a drawing, a word or a photo into a human-like sigma-lognormal drawing motion.",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode="rich",
    pretty_exceptions_enable=False,
)
out = Console()


@app.command("plugins")
def plugins_cmd(
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """List plugins: kind, name, origin and a one-line description."""
    from inkmotion.plugin_host import host

    rows = host().table()
    if as_json:
        print(json.dumps([r.__dict__ for r in rows], indent=1))
        return
    table = Table(box=None, pad_edge=False, header_style="bold underline")
    table.add_column("kind", no_wrap=True)
    table.add_column("name", no_wrap=True)  # what --renderer NAME etc. take: kept whole
    table.add_column("origin", overflow="fold")
    table.add_column("description")
    for r in rows:
        desc = (r.description if r.error is None else f"[yellow]{r.error}[/]"
                if r.description == "disabled" else f"[red]failed to load: {r.error}[/]")
        table.add_row(r.kind, r.name, r.origin, desc)
    out.print(table)


@app.command("bench")
def bench_cmd(
    only: Annotated[Optional[list[str]], typer.Option(  # noqa: UP045
        "--only",
        help="Run only these (repeatable): kinematics, raster, spray, fit, extraction, "
             "recording (the default set); opt-in: queue (fit jobs through a local "
             "redis-server and Celery workers), generation (CLIP tag and abstract, "
             "seconds per step), gallery (build a gallery of 100 jobs, rebuild it), "
             "throughput (minutes: fits per minute side by side and batched), tsp (the "
             "tour solvers), studio (a newcomer's clicks in `inkmotion studio`, in "
             "headless Chromium).")] = None,
    fit_input: Annotated[Optional[str], typer.Option(  # noqa: UP045
        help="Input of the fit benchmark (default: sample:tempt-1, a recorded tag shipped "
             "with inkmotion).")] = None,
    threads: Annotated[int, typer.Option(help="torch threads (the targets assume 2).")] = 2,
    device: Annotated[str, typer.Option(
        help="cpu, cuda or auto: where kinematics, raster and fit run.")] = "cpu",
    as_json: Annotated[bool, typer.Option(
        "--json", help="Print the figures as JSON (value, unit, target, met).")] = False,
    repeat: Annotated[int, typer.Option(
        min=1, max=50, help="Run the fit's warm job this many times and print the median "
                            "(with the fastest and slowest): a machine whose speed drifts "
                            "says little in one run.")] = 1,
) -> None:
    """Print speed figures: kinematics, renderers, a full fit, the recording's cost.

    Each figure is printed with its unit, its target (met, or missed by how much) and a
    line saying what it measures. The raster renderer is timed against a dense baseline
    of the project's own (every piece against every pixel).

    Examples:

      inkmotion bench

      inkmotion bench --only kinematics --only raster

      inkmotion bench --only fit --fit-input sample:tempt-2

      inkmotion bench --only fit --repeat 5

      inkmotion bench --only queue

      inkmotion bench --only generation --device cuda

      inkmotion bench --only studio

      inkmotion bench --only raster --json > raster.json
    """
    from inkmotion.benchmarks.suite import figures_record, run_benchmarks

    try:  # with --json the progress goes to stderr, the figures alone to stdout
        figures = run_benchmarks(only or None, fit_input=fit_input, threads=threads,
                                 console=Console(stderr=True) if as_json else out,
                                 device=device, show=not as_json, repeat=repeat)
    except InkmotionError as exc:
        fail(exc)
    if as_json:
        print(json.dumps(figures_record(figures), indent=1))


def _register_groups() -> None:
    """Add the command groups; `inkmotion --help` lists commands first, then groups, each in
    the order registered here."""
    for group in (run, submit, trace, evaluate, benchmark, samples, render, jobs, worker, view,
                  gallery, clip, robot, studio):
        group.register(app)


_register_groups()


def main() -> None:
    """Entry point of the ``inkmotion`` script: the app's command tree, its help reflowed
    (:mod:`inkmotion.cli.help_text`), run."""
    from inkmotion.cli.help_text import plain_flags, reflow_tree

    plain_flags()
    warnings.formatwarning = _warning_line
    interrupts.install()
    try:
        code = reflow_tree(typer.main.get_command(app)).main(standalone_mode=False)
    except InkmotionError as exc:  # a last guard: user errors never show a traceback
        report(exc)
        sys.exit(EXIT_USER)
    except UsageProblem as exc:  # a usage error: the same one line as the others
        sys.exit(usage_error(exc))
    except Abort:  # Ctrl-C outside a job (a job says what it kept itself)
        report("interrupted.")
        interrupts.exit_interrupted()
    except KeyboardInterrupt:  # one that arrived after a job had reported itself
        interrupts.exit_interrupted()
    except Exception as exc:  # a third-party plugin's bug is named; inkmotion's own shows
        if _from_the_job_store(exc):
            from inkmotion.settings import load_settings
            from inkmotion.store.db import unreachable

            report(unreachable(exc, load_settings().db_url))
            sys.exit(EXIT_USER)
        from inkmotion.plugin_host.manager import TRACEBACK_ENV, plugin_at_fault

        blame = plugin_at_fault(exc)
        if blame is None or os.environ.get(TRACEBACK_ENV) == "1":
            raise
        report(blame)
        sys.exit(EXIT_USER)
    if code == interrupts.EXIT_INTERRUPTED:  # a job ended by a signal, its clean-up said
        interrupts.exit_interrupted()
    sys.exit(code if isinstance(code, int) else 0)


def _from_the_job_store(exc: BaseException) -> bool:
    """Whether ``exc`` is the job store's database refusing (down, unwritable, locked):
    SQLAlchemy's operational errors, which only an imported SQLAlchemy raises."""
    alchemy = sys.modules.get("sqlalchemy.exc")
    return alchemy is not None and isinstance(exc, (alchemy.OperationalError,
                                                    alchemy.InterfaceError))


def _warning_line(message: Warning | str, category: type[Warning], filename: str,
                  lineno: int, line: str | None = None) -> str:
    """A user warning as the command line says everything else, ``warning: …`` on one
    line (not Python's file, line number and source line); other warnings (a library's
    deprecation, for a developer) as Python writes them."""
    if issubclass(category, UserWarning):
        return f"warning: {message}\n"
    return _python_warning_line(message, category, filename, lineno, line)


_python_warning_line = warnings.formatwarning


def usage_error(exc: UsageProblem) -> int:
    """Report a command line click could not take (an unknown option or command, a
    missing argument, a value of the wrong type) as ``error: …`` with where to look;
    returns its exit status (2)."""
    message = exc.format_message().rstrip(".")
    if not message:  # a group called with nothing: click printed its help, which is the answer
        return exc.exit_code
    message = message[:1].lower() + message[1:]
    ctx = getattr(exc, "ctx", None)
    if ctx is not None:  # after click's own question ("Did you mean 'jobs'?") a new sentence
        where = f"`{ctx.command_path} --help` lists what it takes"
        message += f" {where[:1].upper()}{where[1:]}" if message.endswith("?") else f"; {where}"
    report(message + ".")
    return exc.exit_code
