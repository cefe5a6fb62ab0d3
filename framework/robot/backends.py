"""The 'franka-sim' robot backend: a robot program executed in MuJoCo.

Builds the scene from the setup (the board's top face is the calibrated drawing plane),
tracks the joint trajectory at the control rate with the joint impedance controller of
:mod:`inkmotion.robot.mujoco_sim`, and writes

- executed.csv: t, x, y, z of the simulated pen tip (base frame, m) and contact (0/1);
- plan_drawing.png: the plan rendered at its canvas size (what was asked for);
- sim_drawing.png: where the pen touched the board, mapped back to the same canvas;
- side_by_side.png: the two next to each other.

Returns the execution metrics (tracking error, limits, coverage, real-time factor); the
SimResult travels under the private key ``_result`` for :func:`replay`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from inkmotion.robot.types import RobotProgram

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import RenderFunction

#: figures of the execution copied into the job store's metrics
STORE_METRICS = ("tracking_down_plane_rms_mm", "tracking_down_plane_max_mm",
                 "contact_coverage", "real_time_factor")


def render_plan_png(path: Path, plan_file_drawing: Any, canvas: tuple[float, float],
                    renderer: RenderFunction) -> None:
    """The plan drawn by ``renderer`` (the job's 'raster' renderer plugin, handed down by
    the backend's plugin), ink black on white, at its canvas size."""
    from inkmotion.outputs import write_png
    from inkmotion.rendering.drawing import render_plans

    image = render_plans(renderer, plan_file_drawing.plans, (int(canvas[0]), int(canvas[1])))
    write_png(path, image)


def execute_franka_sim(program: RobotProgram, folder: Path, renderer: RenderFunction,
                       replay_rate: float = 30.0) -> dict:
    """Simulate ``program`` and write its files into ``folder`` (see the module docstring);
    ``renderer`` draws plan_drawing.png."""
    from inkmotion.robot.mujoco_sim import execution_metrics, simulate
    from inkmotion.robot.scene import build_scene
    from inkmotion.robot.sim_drawing import write_side_by_side, write_sim_drawing

    setup, cart, joints = program.setup, program.cartesian, program.joints
    plane = setup.plane
    scene = build_scene(board_origin=plane.origin, board_rotation=plane.rotation,
                        board_size=tuple(setup.paper), pen_length=setup.pen_length,
                        timestep=1.0 / float(setup.control_rate))
    sim = simulate(scene, joints.q, joints.rate, pose_rate=replay_rate)
    metrics = execution_metrics(sim, cart.position, cart.pen_down, rate=cart.rate,
                                normal=cart.normal)
    np.savetxt(folder / "executed.csv",
               np.column_stack((sim.t, sim.tip, sim.contact.astype(int))), delimiter=",",
               fmt="%.9g", header="t,x,y,z,contact", comments="")
    canvas = (int(round(program.canvas[0])), int(round(program.canvas[1])))
    width_px = 3.0
    drawing = program.drawing
    if drawing is not None:
        # OpenCV's anti-aliased lines of thickness t cover about t + 1 px
        width_px = max(1.0, float(np.mean([p.width for p in drawing.plans])) - 1.0)
        render_plan_png(folder / "plan_drawing.png", drawing, program.canvas, renderer)
    write_sim_drawing(folder / "sim_drawing.png", sim.contact_strokes(), plane.origin,
                      plane.rotation, tuple(setup.paper), canvas,
                      mapping=program.mapping.plane_to_px, width_px=width_px)
    if (folder / "plan_drawing.png").is_file():
        write_side_by_side(folder / "side_by_side.png", folder / "plan_drawing.png",
                           folder / "sim_drawing.png")
    summary = {k: metrics[k] for k in STORE_METRICS if k in metrics}
    return {**metrics, "metrics": summary, "_result": sim}


def replay(program: RobotProgram, figures: dict, stream: Any) -> None:
    """Log the execution (``figures["_result"]``) into the job's rerun recording."""
    from inkmotion.robot.replay import log_execution

    sim = figures.get("_result")
    if sim is not None:
        log_execution(stream, program, sim)
