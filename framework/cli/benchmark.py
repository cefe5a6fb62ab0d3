"""``inkmotion benchmark INPUTS... --out DIR``: the quality benchmark (did a change make
fitting better?). The work is in :mod:`inkmotion.benchmarks.quality`, imported when the
command runs, so start-up stays light."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console

from inkmotion.cli.errors import fail
from inkmotion.errors import InkmotionError

out = Console()


def benchmark_cmd(
    inputs: Annotated[list[str], typer.Argument(
        help="Drawings (GML/JSON/SVG), folders of them, or text:WORD.", show_default=False)],
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
        min=1, help="Adam steps per fit (default: the fit's, 600).")] = None,
    size: Annotated[Optional[int], typer.Option(  # noqa: UP045
        min=32, help="Canvas longer side, px (default: the fit's, 350).")] = None,
    param: Annotated[Optional[list[str]], typer.Option(  # noqa: UP045
        "--param", "-p", metavar="KEY=VALUE",
        help="A fit parameter (VALUE read as JSON, else a string), repeatable; "
             "PLUGIN.OPTION sets a plugin's option, e.g. initialiser.threshold=20.")] = None,
    device: Annotated[str, typer.Option(help="cpu, cuda or auto.")] = "cpu",
    seed: Annotated[int, typer.Option(min=0, help="Seed of every fit.")] = 0,
) -> None:
    """Fit every input with the default settings and report the fit quality per item and
    over the set: sub-movements m, Chamfer mean/max (px), IoU of the rendered fit against
    the target, T_end reduction, share of Δt on a clamp, steps and wall time.

    A failing item is one row with its error (exit status 1, summaries written).

    Examples:

      inkmotion benchmark tags/4986*.json --out bench/base

      inkmotion benchmark tags/ text:hello --out bench/lambda40 --param lambda_smooth=40

      inkmotion benchmark text:hello text:inkmotion --out bench/quick --steps 50 --size 200 --jobs 2

      inkmotion benchmark tags/ --out bench/sparse --param initialiser.threshold=20

      inkmotion benchmark tags/ --out bench/batched --jobs 2 --batch 9
    """
    if out_dir is None:
        fail("give the output folder: --out DIR.", code=2)
    from inkmotion.benchmarks.quality import parse_param, run_benchmark

    try:
        params = dict(parse_param(p) for p in param or [])
        summary = run_benchmark(inputs, out_dir, jobs=jobs, steps=steps, size=size,
                                params=params, console=out, device=device, seed=seed,
                                batch=batch)
    except InkmotionError as exc:
        fail(exc)
    out.print(f"summaries in {out_dir} (summary.md, summary.html, summary.csv, summary.json)",
              highlight=False)
    failed = summary["totals"]["failed"]
    if failed:
        fail(f"{failed} of {summary['totals']['items']} items failed; their errors are in "
             f"{out_dir / 'summary.md'}.")


def register(app: typer.Typer) -> None:
    """Add ``benchmark`` to the ``inkmotion`` app."""
    app.command("benchmark")(benchmark_cmd)
