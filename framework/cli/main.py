"""The ``inkmotion`` command line (typer)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from inkmotion.cli import spec_options as opts
from inkmotion.errors import InkmotionError

app = typer.Typer(
    name="inkmotion",
    help="Turn a drawing, a word or a photo into a human-like sigma-lognormal drawing motion.",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode="rich",
    pretty_exceptions_enable=False,
)
run_app = typer.Typer(
    help=(
        "Run a job in this process (no services needed).\n\n"
        "Examples:\n\n"
        "  inkmotion run fit text:hello --out results/hello\n\n"
        "  inkmotion run fit tag.gml --out results/tag --steps 300 --size 350\n\n"
        "  inkmotion run --config results/tag/job.json --out results/again"
    ),
    no_args_is_help=False,
)
app.add_typer(run_app, name="run")
err = Console(stderr=True)
out = Console()


def fail(exc: BaseException, code: int = 1) -> None:
    """Report a user-caused error in one sentence, no traceback, and exit."""
    err.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
    raise typer.Exit(code)


def _execute(spec: object, out_dir: Path, record: bool) -> None:
    from inkmotion.jobs.runner import run_job

    observers = []
    if record:
        try:
            from inkmotion.recording import RerunRecorder
        except ImportError:  # recording package not available
            RerunRecorder = None  # noqa: N806
        if RerunRecorder is not None:
            observers.append(RerunRecorder(image_every=spec.params.record_every))  # type: ignore[attr-defined]
    try:
        report = run_job(spec, out_dir, observers=observers)  # type: ignore[arg-type]
    except InkmotionError as exc:
        fail(exc)
    except KeyboardInterrupt:
        err.print(f"interrupted; nothing was written to {out_dir}")
        raise typer.Exit(130) from None
    out.print(
        f"[green]done[/] in {report['wall_s']:.1f} s: {report['paths']} paths, "
        f"{report['moves']} lognormals, Chamfer {report['chamfer_mean_px']:.2f} px mean / "
        f"{report['chamfer_max_px']:.1f} px max, T_end {report['t_end_ratio']:.2f}× initial"
    )
    out.print(f"results in [bold]{out_dir}[/] (plan.json, drawing.svg, overlay.png, speed.png, "
              "report.json, ...)")


@run_app.callback(invoke_without_command=True)
def run_main(
    ctx: typer.Context,
    config: Annotated[Optional[Path], typer.Option(  # noqa: UP045 - typer needs Optional
        "--config", help="A job.json (or spec JSON) to reproduce.")] = None,
    out_dir: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--out", help="Output folder for --config runs.")] = None,
    record: Annotated[bool, typer.Option(help="Write recording.rrd (rerun).")] = True,
) -> None:
    """Run a job in this process."""
    if ctx.invoked_subcommand is not None:
        return
    if config is None or out_dir is None:
        err.print(ctx.get_help())
        fail(InkmotionError("give a subcommand (e.g. `inkmotion run fit INPUT --out DIR`) "
                            "or --config job.json --out DIR."), code=2)
    from inkmotion.jobs.spec import JobSpec

    try:
        spec = JobSpec.load(config)
        spec.validate()
    except InkmotionError as exc:
        fail(exc)
    _execute(spec, out_dir, record)


@run_app.command("fit")
def run_fit(
    input: Annotated[str, typer.Argument(help="GML/JSON/SVG file, or text:WORD.")],
    out_dir: Annotated[Path, typer.Option("--out", help="Output folder (written atomically).")],
    config: opts.ConfigOpt = None,
    steps: opts.StepsOpt = None,
    size: opts.SizeOpt = None,
    seed: opts.SeedOpt = None,
    lambda_smooth: opts.LambdaOpt = None,
    w_image: opts.WImageOpt = None,
    width: opts.WidthOpt = None,
    dce_threshold: opts.DceOpt = None,
    initialiser: opts.InitialiserOpt = None,
    renderer: opts.RendererOpt = None,
    loss: opts.LossOpt = None,
    device: opts.DeviceOpt = None,
    record_every: opts.RecordEveryOpt = None,
    record: Annotated[bool, typer.Option(help="Write recording.rrd (rerun).")] = True,
) -> None:
    """Fit a ΣΛ motion to a drawing (the paper's "fitting trajectories to an image").

    Examples:

      inkmotion run fit text:hello --out results/hello

      inkmotion run fit ../shared/data/gml/49867.json --out results/49867 --steps 300

      inkmotion run fit tag.gml --out results/smoother --lambda 150 --size 500
    """
    try:
        spec = opts.spec_from_cli(
            "fit", input, config=config, steps=steps, size=size, seed=seed,
            lambda_smooth=lambda_smooth, w_image=w_image, width=width,
            dce_threshold=dce_threshold, initialiser=initialiser, renderer=renderer, loss=loss,
            device=device, record_every=record_every)
    except InkmotionError as exc:
        fail(exc)
    _execute(spec, out_dir, record)


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
) -> None:
    """Print speed figures (kinematics, raster, a full fit, recording overhead).

    Examples:

      inkmotion bench

      inkmotion bench --only kinematics --only raster

      inkmotion bench --only queue
    """
    from inkmotion.benchmarks.suite import run_benchmarks

    try:
        run_benchmarks(only or None, fit_input=fit_input, threads=threads, console=out)
    except InkmotionError as exc:
        fail(exc)


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
