"""The 'simulate' job kind's work: setup → timing → joint trajectory → backends.

Stages are reported as steps (1: timing, 2: joint trajectory, then one per backend), so
the progress bar and the job store follow a long simulation. Everything that can refuse
the job (setup file, plan file, reachability) runs before any motion is planned in full;
nothing is written until the plan is known to be feasible.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from inkmotion.events import StepState
from inkmotion.robot.types import RobotProgram

if TYPE_CHECKING:
    from inkmotion.jobs.shell import Job
    from inkmotion.robot.setup import RobotSetup
    from inkmotion.sigma_lognormal import Drawing


def job_setup(setup_path: str, v_max: float, a_max: float) -> RobotSetup:
    """The setup file (or the shipped default) with the job's speed limits when given."""
    from inkmotion.robot.setup import load_setup

    overrides: dict[str, Any] = {}
    if v_max > 0:
        overrides["v_max"] = v_max
    if a_max > 0:
        overrides["a_max"] = a_max
    return load_setup(setup_path or None, overrides or None)


def plan_program(drawing: Drawing, setup: RobotSetup,
                 on_stage: Any = None) -> RobotProgram:
    """Time the drawing on the setup and solve its joint trajectory (raises InputError with
    one sentence for an unreachable drawing, before any joint trajectory is solved)."""
    from inkmotion.robot.calibration import PaperMapping
    from inkmotion.robot.joints import solve_joint_trajectory
    from inkmotion.robot.kinematics import check_reachable, pen_model, pen_poses
    from inkmotion.robot.timing import time_drawing

    t0 = time.perf_counter()
    mapping = PaperMapping.from_canvas(drawing.canvas, setup.paper, setup.margin)
    home_tip, _ = pen_poses(pen_model(setup.pen_length), setup.home[None])
    cartesian = time_drawing(drawing, setup, start=home_tip[0], mapping=mapping)
    check_reachable(cartesian.position, cartesian.normal, setup.pen_length,
                    joint_margin=setup.joint_margin, stroke=cartesian.stroke)
    timing_s = time.perf_counter() - t0
    if on_stage is not None:
        on_stage(1, "timing")
    t1 = time.perf_counter()
    joints = solve_joint_trajectory(cartesian, pen_length=setup.pen_length, home=setup.home,
                                    joint_margin=setup.joint_margin, q_start=setup.home)
    joints_s = time.perf_counter() - t1
    if on_stage is not None:
        on_stage(2, "joints")
    info = {"timing_s": round(timing_s, 3), "joints_s": round(joints_s, 3),
            "planning_s": round(timing_s + joints_s, 3)}
    return RobotProgram(setup, mapping, drawing.canvas, cartesian, joints, info, drawing)


def write_program(folder: Path, program: RobotProgram) -> None:
    """joints.csv (t, q1..q7) and cartesian.csv (t, x, y, z, pen_down) at the control rate,
    and setup.toml as used."""
    cart, joints = program.cartesian, program.joints
    header = "t," + ",".join(f"q{i}" for i in range(1, 8))
    np.savetxt(folder / "joints.csv", np.column_stack((joints.t, joints.q)), delimiter=",",
               fmt="%.9g", header=header, comments="")
    np.savetxt(folder / "cartesian.csv",
               np.column_stack((cart.t, cart.position, cart.pen_down.astype(int))),
               delimiter=",", fmt="%.9g", header="t,x,y,z,pen_down", comments="")
    (folder / "setup.toml").write_text(program.setup.source, encoding="utf-8")


def run_simulate(job: Job) -> dict[str, Any]:
    """Load the plan and the setup, plan the robot program, run every backend."""
    from inkmotion.sigma_lognormal import Drawing

    p = job.params
    drawing = Drawing.load(job.spec.inputs["plan"])
    setup = job_setup(p.setup, p.v_max, p.a_max)
    job.start((int(drawing.canvas[0]), int(drawing.canvas[1])))
    total = job.total_steps

    def stage(step: int, name: str, seconds: float = 0.0) -> None:
        job.observers.on_step(StepState(step, total, {"stage_s": seconds}, 0.0))

    program = plan_program(drawing, setup, on_stage=lambda k, name: stage(k, name))
    write_program(job.folder, program)
    cart, joints = program.cartesian, program.joints
    report: dict[str, Any] = {
        "duration_s": float(cart.t[-1]),
        "drawing_s": cart.info.get("drawing_s"),
        "time_scale": cart.time_scale,
        "timing": cart.info,
        "joint_trajectory": {"max_position_error_mm": 1e3 * joints.max_position_error,
                             "max_orientation_error_deg":
                                 float(np.degrees(joints.max_orientation_error)),
                             **joints.info},
        "planning": program.info,
        "setup": {"v_max": setup.v_max, "a_max": setup.a_max, "pen_length": setup.pen_length,
                  "control_rate": setup.control_rate,
                  "plane_residual_mm": 1e3 * float(setup.plane.residual),
                  "m_per_px": program.mapping.scale},
        "paths": len(drawing.plans),
        "moves": sum(plan.m for plan in drawing.plans),
    }
    metrics = {"duration_s": report["duration_s"],
               "ik_max_position_error_mm": report["joint_trajectory"]["max_position_error_mm"]}
    for i, choice in enumerate(p.backends, start=3):
        backend = job.plugin(choice)
        started = time.perf_counter()
        figures = backend.execute(program, job.folder, **job.options(choice))
        stream = job.recording_stream()
        replay = getattr(backend, "replay", None)
        if stream is not None and replay is not None:
            replay(program, figures, stream)
        figures = {k: v for k, v in figures.items() if not k.startswith("_")}
        report[choice.name] = figures
        metrics.update(figures.get("metrics", {}))
        stage(i, choice.name, time.perf_counter() - started)
    report["metrics"] = metrics
    return report
