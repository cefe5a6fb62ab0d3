"""``inkmotion robot``: the bench around a real arm (teach the drawing plane).

franky, NumPy and Pinocchio load inside the commands."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console

from inkmotion.cli.errors import fail
from inkmotion.errors import InkmotionError

out = Console(stderr=True)
robot_app = typer.Typer(name="robot", help="A real Franka's bench: teach the drawing plane.",
                        no_args_is_help=True, add_completion=False)


@robot_app.command("teach")
def teach_cmd(
    robot: Annotated[str, typer.Option("--robot", help="The robot's FCI hostname or IP.")],
    out_file: Annotated[Path, typer.Option("--out", help="The setup TOML to write.")],
    setup: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--setup", help="Start from this setup (pen, limits, home); default: the shipped one."
    )] = None,
    realtime: Annotated[str, typer.Option(
        help="enforce (a real arm) or ignore (simulators and test benches).")] = "enforce",
    force: Annotated[bool, typer.Option("--force", help="Replace --out if it exists.")] = False,
) -> None:
    """Teach the drawing plane: four corners, guided by hand, make a setup file.

    Guide the pen tip onto the four corners of the drawing area (Enter at each); the setup
    file written has the plane and the paper of those corners. The arm floats while you
    guide it (a very soft joint impedance that follows your hand); hold it by the pen
    holder, set the tip on each corner in order around the area, press Enter. The corners
    are checked (planar, a rectangle that holds the paper) before the file is written.

    Examples:

      inkmotion robot teach --robot 172.16.0.2 --out bench.toml

      inkmotion robot teach --robot 172.16.0.2 --setup my_pen.toml --out bench.toml --force

      inkmotion run draw plan.json --robot 172.16.0.2 --setup bench.toml --dry-run --out r/d
    """
    from inkmotion.outputs import refuse_to_overwrite
    from inkmotion.outputs.atomic import write_bytes_atomic
    from inkmotion.robot import franka
    from inkmotion.robot.setup import load_setup, setup_to_toml
    from inkmotion.robot.teach import CORNERS, taught_setup, teach_corners

    try:
        refuse_to_overwrite(out_file, force, folder=False)
    except InkmotionError as exc:
        fail(exc)
    if realtime not in ("enforce", "ignore"):
        fail(f"--realtime {realtime!r} is not enforce or ignore; pass one of those.")
    try:
        base = load_setup(setup)

        def wait(i: int) -> None:
            out.print(f"Guide the pen tip onto the {CORNERS[i]} corner, then press Enter.",
                      highlight=False, soft_wrap=True)
            input()

        with franka.scheduling_kept():
            arm = franka.connect(robot, realtime=realtime == "enforce")
            corners = teach_corners(arm, base.pen_length, wait)
        taught = taught_setup(corners, setup)
        write_bytes_atomic(out_file, setup_to_toml(taught).encode("utf-8"))
    except (InkmotionError, EOFError) as exc:
        fail(exc if isinstance(exc, InkmotionError) else
             "standard input closed before the four corners were taught; teach again.")
    residual_mm = 1e3 * float(taught.plane.residual)
    out.print(f"{out_file}: plane taught, corners within {residual_mm:.2f} mm of their plane, "
              f"paper {taught.paper[0]:.3f} × {taught.paper[1]:.3f} m.", highlight=False,
              soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Add the ``robot`` group to the ``inkmotion`` app."""
    app.add_typer(robot_app)
