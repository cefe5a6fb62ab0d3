"""``inkmotion benchmark INPUTS... --out DIR``: the quality benchmark (did a change make
fitting better?). The work is in :mod:`inkmotion.benchmarks.quality`, imported when the
command runs, so start-up stays light."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.console import Console
from typer.core import TyperCommand

from inkmotion.cli.errors import fail
from inkmotion.cli.interrupts import EXIT_INTERRUPTED
from inkmotion.cli.run import FORCE_HELP
from inkmotion.errors import InkmotionError
from inkmotion.json_files import dumps

out = Console()
err = Console(stderr=True)
#: what --steps and --size say of their default; ``--help`` adds the fit's number
FIT_DEFAULT = "the fit's"


class BenchmarkCommand(TyperCommand):
    """``benchmark``'s command, whose ``--help`` shows the fit's own defaults of --steps and
    --size, read from the fit's declaration (:class:`inkmotion.kinds.fit.FitParams`) only
    when help is asked for, so starting the command line costs nothing for it."""

    def format_help(self, ctx: Any, formatter: Any) -> None:
        from dataclasses import fields

        from inkmotion.kinds.fit import FitParams

        defaults = {f.name: f.default for f in fields(FitParams)}
        for option in self.params:
            text = getattr(option, "help", None)
            if option.name in ("steps", "size") and text:
                option.help = text.replace(f"{FIT_DEFAULT})",  # type: ignore[attr-defined]
                                           f"{FIT_DEFAULT}, {defaults[option.name]})")
        super().format_help(ctx, formatter)


def benchmark_cmd(
    inputs: Annotated[list[str], typer.Argument(
        help="Drawings (GML/JSON/SVG, or pictures of line art: PNG, JPEG, ...), folders of "
             "them, sample:NAME or text:WORD.",
        show_default=False)],
    out_dir: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--out", help="Output folder: one folder per item and summary.{json,csv,md,html}.")
    ] = None,
    jobs: Annotated[Optional[int], typer.Option(  # noqa: UP045
        "--jobs", "-j", min=1, help="Items fitted in parallel (default: min(cores, items, 4)).")
    ] = None,
    batch: Annotated[int, typer.Option(
        "--batch", "-b", min=1, help="Items each parallel job fits as one batched "
        "optimisation (same quality, fewer per-op costs).")] = 1,
    steps: Annotated[Optional[int], typer.Option(  # noqa: UP045
        min=1, help=f"Adam steps per fit (default: {FIT_DEFAULT}).")] = None,
    size: Annotated[Optional[int], typer.Option(  # noqa: UP045
        min=32, help=f"Canvas longer side, px (default: {FIT_DEFAULT}).")] = None,
    param: Annotated[Optional[list[str]], typer.Option(  # noqa: UP045
        "--param", "-p", metavar="KEY=VALUE",
        help="A fit parameter (VALUE read as JSON, else a string), repeatable; "
             "PLUGIN.OPTION sets a plugin's option, e.g. initialiser.threshold=20.")] = None,
    device: Annotated[str, typer.Option(help="cpu, cuda or auto.")] = "cpu",
    seed: Annotated[int, typer.Option(min=0, help="Seed of every fit.")] = 0,
    force: Annotated[bool, typer.Option(
        "--force", help=FORCE_HELP)] = False,
    as_json: Annotated[bool, typer.Option(
        "--json", help="Print the summary (items and aggregate) as JSON; the table and the "
        "progress go to stderr.")] = False,
) -> None:
    """Fit every input and report how good the fits are, per item and over the set.

    The figures: sub-movements m, Chamfer mean/max (px), IoU of the rendered fit against
    the target, T_end reduction, share of Δt on a clamp, steps and wall time. A failing
    item is one row with its error (exit status 1, summaries written). DIR appears only
    once every item is done; Ctrl-C leaves nothing.

    Examples:

      inkmotion benchmark sample:tempt-1 sample:tempt-2 --out results/bench

      inkmotion benchmark sample:tempt-1 --out results/l40 -p lambda_smooth=40

      inkmotion benchmark text:hi text:ink --out results/quick --steps 50

      inkmotion benchmark MY_TAGS/ --out results/batched --jobs 2 --batch 9
    """
    if out_dir is None:
        fail("give the output folder: --out DIR.", code=2)
    from inkmotion.benchmarks.quality import parse_param, run_benchmark

    try:
        params = dict(parse_param(p) for p in param or [])
        summary = run_benchmark(inputs, out_dir, jobs=jobs, steps=steps, size=size,
                                params=params, console=err if as_json else out,
                                device=device, seed=seed, batch=batch, force=force)
    except InkmotionError as exc:
        fail(exc)
    except KeyboardInterrupt:
        typer.echo(f"interrupted; nothing was written to {out_dir}", err=True)
        raise typer.Exit(EXIT_INTERRUPTED) from None
    (err if as_json else out).print(
        f"summaries in {out_dir} (summary.md, summary.html, summary.csv, summary.json)",
        highlight=False)
    if as_json:
        print(dumps(summary, str, indent=1))
    failed = summary["totals"]["failed"]
    if failed:
        fail(f"{failed} of {summary['totals']['items']} items failed; their errors are in "
             f"{out_dir / 'summary.md'}.")


def register(app: typer.Typer) -> None:
    """Add ``benchmark`` to the ``inkmotion`` app."""
    app.command("benchmark", cls=BenchmarkCommand)(benchmark_cmd)
