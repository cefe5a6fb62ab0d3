"""``inkmotion evaluate PLAN.json --out DIR``: the 'evaluate' job kind as a top-level
command (the same as ``inkmotion run evaluate``), ΣΛ against minimum-jerk and time-optimal
timings of the same path. Nothing heavy is imported until the command runs."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from inkmotion.cli.run import ForceOpt, JsonOpt, OutOpt, RecordOpt


def evaluate_cmd(
    plan: Annotated[str, typer.Argument(help="A plan.json (fit, tag or abstract job).")],
    out_dir: OutOpt = None,
    vmax: Annotated[float, typer.Option("--vmax", help="Pen speed limit, m/s.")] = 0.25,
    amax: Annotated[float, typer.Option("--amax", help="Pen acceleration limit, m/s².")] = 2.5,
    path: Annotated[int, typer.Option(
        help="Which path of the plan (0-based); -1: every path, per path and over the "
        "drawing (the plots show the longest).")] = -1,
    rate: Annotated[float, typer.Option(help="Sampling rate, Hz.")] = 1000.0,
    setup: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        help="Robot setup TOML whose paper maps px to metres.")] = None,
    recording: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        help="The GML/JSON the plan was fitted to (its time stamps: human agreement).")
    ] = None,
    recording_time_unit: Annotated[str, typer.Option(
        help="The unit of the recording's time stamps: s, ms or auto (told by their step).")
    ] = "auto",
    record: RecordOpt = False,
    force: ForceOpt = False,
    as_json: JsonOpt = False,
) -> None:
    """Compare ΣΛ with path-constrained minimum jerk and time-optimal (TOPP-RA) timings.

    Writes evaluation.json / .csv (duration, MSJ, LDJ per method and the ratios method/ΣΛ,
    > 1: ΣΛ better), speeds.png and minima.png.

    Examples:

      inkmotion evaluate results/tag/plan.json --out results/tag-eval

      inkmotion evaluate results/tag/plan.json --vmax 0.5 --amax 5 --out results/fast-eval

      inkmotion evaluate results/tag/plan.json --recording sample:tempt-1 --out results/rec
    """
    from inkmotion.cli.run import _run_kind

    values = {"out_dir": out_dir, "record": record, "force": force, "as_json": as_json,
              "config": None, "v_max": vmax, "a_max": amax, "path": path, "rate": rate,
              "setup": str(setup) if setup else None,
              "recording": str(recording) if recording else None,
              "recording_time_unit": recording_time_unit}
    _run_kind("evaluate", [plan], values)


def register(app: typer.Typer) -> None:
    """Add ``evaluate`` to the ``inkmotion`` app."""
    app.command("evaluate")(evaluate_cmd)
