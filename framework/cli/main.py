"""The ``inkmotion`` command line (typer)."""

from __future__ import annotations

import json
import sys
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from inkmotion.errors import InkmotionError

app = typer.Typer(
    name="inkmotion",
    help="Turn a drawing, a word or a photo into a human-like sigma-lognormal drawing motion.",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode="rich",
    pretty_exceptions_enable=False,
)
err = Console(stderr=True)
out = Console()


def fail(exc: BaseException, code: int = 1) -> None:
    """Report a user-caused error in one sentence, no traceback, and exit."""
    err.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
    raise typer.Exit(code)


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
    table = Table("kind", "name", "origin", "description")
    for r in rows:
        desc = r.description if r.error is None else f"[red]failed to load: {r.error}[/]"
        table.add_row(r.kind, r.name, r.origin, desc)
    out.print(table)


@app.command("bench")
def bench_cmd(
    only: Annotated[Optional[list[str]], typer.Option(  # noqa: UP045
        "--only",
        help="Run only these: kinematics, raster, fit, recording (the default set), or "
             "queue (opt-in: starts a local redis-server and 2 workers).")] = None,
    fit_input: Annotated[Optional[str], typer.Option(  # noqa: UP045
        help="Input of the fit benchmark (default: ../shared 49867.json, else text:inkmotion).")
    ] = None,
    threads: Annotated[int, typer.Option(help="torch threads (the targets assume 2).")] = 2,
    device: Annotated[str, typer.Option(
        help="cpu, cuda or auto: where kinematics, raster and fit run.")] = "cpu",
) -> None:
    """Print speed figures (kinematics, raster, a full fit, recording overhead).

    Examples:

      inkmotion bench

      inkmotion bench --only kinematics --only raster

      inkmotion bench --only queue

      inkmotion bench --device cuda
    """
    from inkmotion.benchmarks.suite import run_benchmarks

    try:
        run_benchmarks(only or None, fit_input=fit_input, threads=threads, console=out,
                       device=device)
    except InkmotionError as exc:
        fail(exc)


def _register_run() -> None:
    from inkmotion.cli import run, submit

    run.register(app)
    submit.register(app)


_register_run()


def _register_services() -> None:
    try:
        from inkmotion.cli.services import register
    except ImportError:
        return
    register(app)


_register_services()


def main() -> None:
    """Entry point of the ``inkmotion`` script."""
    try:
        app()
    except InkmotionError as exc:  # a last guard: user errors never show a traceback
        err.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
        sys.exit(1)
