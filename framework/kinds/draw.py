"""The 'draw' job kind's work: a Franka draws a plan, through libfranka (franky).

Stages (the progress bar's steps): 1 connect and identify the arm, 2 timing, 3 joint
trajectory within the connected model's limits (retimed where needed), 4 checks and the
approach to the start pose, 5 the drawing streamed at 1 kHz, 6 the record written.
Everything that can refuse the job runs before the arm moves: the connection (within 10 s),
the model, the setup and the plan, reachability, the limits, the arm's distance from the
start pose. ``dry_run`` stops after the checks, with the arm untouched.

A drawing that does not finish (a fault, a reflex, Ctrl-C, SIGTERM, a lost connection)
leaves the arm stopped and its job folder absent, as any failed job; what was recorded up to
the stop goes to ``DIR.stopped`` beside it (report.json with ``completed: false`` and the
reason, executed.csv up to the stop), and the job fails with one sentence saying how far it
got and where that record is.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from inkmotion.errors import RobotError
from inkmotion.events import StepState
from inkmotion.json_files import dumps
from inkmotion.kinds.simulate import job_setup, program_report, write_program

if TYPE_CHECKING:
    from inkmotion.jobs.shell import Job
    from inkmotion.robot.franka import Execution
    from inkmotion.robot.limits import ArmLimits
    from inkmotion.robot.types import RobotProgram

#: m: an executed pen tip this close to the plane counts as drawing (robot_drawing.png)
DRAWN_GAP = 0.001
STEPS = 6
#: the stage that follows each step, as the progress bar names it
NEXT = {1: "timing", 2: "joint trajectory", 3: "checks and approach", 4: "drawing",
        5: "record"}


def run_draw(job: Job) -> dict[str, Any]:
    """Connect, plan, check, approach, draw, write (module docstring)."""
    from inkmotion.robot import franka
    from inkmotion.robot.program import plan_program
    from inkmotion.sigma_lognormal import Drawing

    p = job.params
    drawing = Drawing.load(job.input_file("plan"))
    setup = job_setup(p.setup, p.v_max, p.a_max)
    job.start((int(drawing.canvas[0]), int(drawing.canvas[1])))

    def stage(step: int, figures: dict[str, float]) -> None:
        """Stage ``step`` is done; the bar shows its ``figures`` and the stage that runs now."""
        now = {"now": NEXT[step]} if step in NEXT else {}
        job.observers.on_step(StepState(step, STEPS, {}, None, figures={**now, **figures}))

    with franka.scheduling_kept():  # libfranka leaves this thread at SCHED_FIFO 99
        robot = franka.connect(p.robot, realtime=p.realtime == "enforce")
        arm = franka.connected_arm(robot, p.model)
        stage(1, {"connect_s": time.perf_counter() - job.started})
        program = plan_program(drawing, setup, arm=arm,
                               on_stage=lambda i, name: stage(i + 1, {}))
        q_now = franka.joint_positions(robot)
        franka.check_start(q_now, program.joints.q[0], arm, p.max_approach)
        write_program(job.folder, program)
        report = program_report(program)
        report["robot"] = {"host": p.robot, "model": arm.name, "realtime": p.realtime,
                           "start_distance_rad": float(np.abs(q_now - program.joints.q[0]).max()),
                           "limits": _limits_table(arm)}
        if p.dry_run:
            stage(4, {})
            report["dry_run"] = True
            report["metrics"] = {"duration_s": report["duration_s"],
                                 "limit_min_margin": program.info["limits"]["min_margin"]}
            return report
        approach_s = franka.approach(robot, program.joints.q[0], p.approach_speed)
        stage(4, {"approach_s": approach_s})
        started_after = time.perf_counter() - job.started
        execution = franka.stream(robot, program.joints.q, program.joints.rate)
        report["robot"].update({"approach_s": approach_s, "drawing_started_after_s": started_after})
        if not execution.completed:
            _stopped(job, program, execution, report, robot, p.recover)
        stage(5, {"drawn_s": execution.duration})
        figures = write_execution(job.folder, program, execution, arm, job)
        report["robot"].update(figures)
        report["completed"] = True
        report["metrics"] = {k: figures[k] for k in (
            "flange_rms_mm", "flange_max_mm", "tracking_down_plane_rms_mm",
            "tracking_down_plane_max_mm", "real_time_factor")} | {
            "duration_s": report["duration_s"], "drawing_started_after_s": started_after}
        stage(6, {})
        return report


def _limits_table(arm: ArmLimits) -> dict[str, list[float]]:
    return {"position_lower": arm.lower.tolist(), "position_upper": arm.upper.tolist(),
            "velocity": arm.velocity.tolist(), "acceleration": arm.acceleration.tolist(),
            "jerk": arm.jerk.tolist()}


def _stopped(job: Job, program: RobotProgram, execution: Execution, report: dict,
             robot: Any, recover: bool) -> None:
    """Keep the record of an unfinished drawing in ``DIR.stopped`` and fail the job."""
    from inkmotion.robot import franka

    recovered = franka.recover(robot) if recover else None
    final = _final_folder(job.folder)
    stopped = final.with_name(final.name + ".stopped")
    if stopped.exists():
        shutil.rmtree(stopped)
    stopped.mkdir(parents=True)
    for name in ("joints.csv", "cartesian.csv", "setup.toml"):
        shutil.copy(job.folder / name, stopped / name)
    _write_executed(stopped / "executed.csv", program, execution)
    total = float(program.joints.t[-1])
    report.update({"completed": False, "stop_reason": execution.stop_reason,
                   "stopped_at_s": execution.duration, "of_s": total,
                   "recovered": recovered})
    (stopped / "report.json").write_text(dumps(report, float, indent=1) + "\n",
                                         encoding="utf-8")
    after = "" if recovered is None else (" errors cleared;" if recovered else
                                          " clearing its errors failed;")
    raise RobotError(
        f"The drawing stopped at {execution.duration:.2f} s of {total:.2f} s: "
        f"{execution.stop_reason}; the arm is stopped,{after} what it did is in {stopped} "
        "(nothing was written to the job folder).")


def _final_folder(staging: Path) -> Path:
    """The job's final folder from its staging folder ``DIR.partial-<owner>-<random>``."""
    name = staging.name
    cut = name.rfind(".partial-")
    return staging.with_name(name[:cut] if cut > 0 else name)


def _write_executed(path: Path, program: RobotProgram, execution: Execution) -> np.ndarray:
    """executed.csv: the robot's reported states and the pen tip by forward kinematics;
    returns the tips (N, 3)."""
    from inkmotion.robot.kinematics import pen_model, pen_poses

    tip, _ = pen_poses(pen_model(program.setup.pen_length), execution.q) \
        if len(execution.q) else (np.zeros((0, 3)), None)
    columns = (["t"] + [f"q{i}" for i in range(1, 8)] + [f"dq{i}" for i in range(1, 8)]
               + [f"tau{i}" for i in range(1, 8)] + ["x", "y", "z"])
    rows = np.column_stack((execution.t, execution.q, execution.dq, execution.tau, tip))
    tmp = path.with_name(path.name + ".tmp")
    np.savetxt(tmp, rows, delimiter=",", fmt="%.9g", header=",".join(columns), comments="")
    tmp.replace(path)
    return tip


def write_execution(folder: Path, program: RobotProgram, execution: Execution,
                    arm: ArmLimits, job: Job | None = None) -> dict[str, Any]:
    """executed.csv, plan_drawing.png, robot_drawing.png, side_by_side.png and the
    recording; returns the execution's figures (:func:`execution_figures`)."""
    from inkmotion.robot.backends import render_plan_png
    from inkmotion.robot.sim_drawing import write_side_by_side, write_sim_drawing
    from inkmotion.robot.tracking import runs

    tip = _write_executed(folder / "executed.csv", program, execution)
    figures = execution_figures(program, execution, tip, arm)
    plane, setup = program.setup.plane, program.setup
    gap = (tip - plane.origin) @ plane.normal
    strokes = [tip[a:b] for a, b in runs(gap <= DRAWN_GAP)]
    canvas = (int(round(program.canvas[0])), int(round(program.canvas[1])))
    width_px = max(1.0, float(np.mean([p.width for p in program.drawing.plans])) - 1.0)
    renderer = _raster()
    render_plan_png(folder / "plan_drawing.png", program.drawing, program.canvas, renderer)
    write_sim_drawing(folder / "robot_drawing.png", strokes, plane.origin, plane.rotation,
                      tuple(setup.paper), canvas, mapping=program.mapping.plane_to_px,
                      width_px=width_px)
    write_side_by_side(folder / "side_by_side.png", folder / "plan_drawing.png",
                       folder / "robot_drawing.png", labels=("plan", "robot"))
    stream = job.recording_stream() if job is not None else None
    if stream is not None:
        from inkmotion.robot.replay import log_arm_execution

        log_arm_execution(stream, program, execution.t, execution.q, tip)
    return figures


def _raster() -> Any:
    from inkmotion.plugin_host import host

    return host().get("renderer", "raster")


def execution_figures(program: RobotProgram, execution: Execution, tip: np.ndarray,
                      arm: ArmLimits) -> dict[str, Any]:
    """Tracking of the flange and the pen tip against the plan at the robot's own clock
    (the plan sample nearest each reported state), and the reported motion against the
    connected model's limits."""
    from inkmotion.robot import limits
    from inkmotion.robot.kinematics import pen_model, pen_poses
    from inkmotion.robot.tracking import error_stats

    cart, joints = program.cartesian, program.joints
    rate = joints.rate
    k = np.clip(np.round(execution.t * rate).astype(int), 0, len(joints.q) - 1)
    inside = execution.t <= joints.t[-1] + 0.5 / rate
    k, q = k[inside], execution.q[inside]
    flange = pen_model(0.0)
    measured_flange, _ = pen_poses(flange, q)
    planned_flange, _ = pen_poses(flange, joints.q[k])
    n = program.setup.plane.normal
    flange_err = np.linalg.norm(measured_flange - planned_flange, axis=1)
    figures: dict[str, Any] = {
        "flange_rms_mm": 1e3 * float(np.sqrt(np.mean(flange_err**2))),
        "flange_max_mm": 1e3 * float(flange_err.max()),
        "joint_error_max_rad": np.abs(q - joints.q[k]).max(axis=0).tolist(),
    }
    pen_down = cart.pen_down[k]
    err = tip[inside] - cart.position[k]
    figures.update(error_stats(err, pen_down, n, "tracking_down"))
    figures.update(error_stats(err, np.ones(len(k), bool), n, "tracking_all"))
    figures.update(limits.limit_figures("reported_joint_velocity",
                                        np.abs(execution.dq).max(axis=0), arm.velocity))
    steps = np.maximum(np.diff(execution.t), 0.5 / rate)[:, None]  # a missed cycle is longer
    ddq = np.abs(np.diff(execution.dq, axis=0) / steps)
    figures.update(limits.limit_figures("reported_joint_acceleration",
                                        ddq.max(axis=0) if len(ddq) else np.zeros(7),
                                        arm.acceleration))
    for name, (order, limit) in arm.by_order().items():
        figures.update(limits.limit_figures(f"planned_joint_{name}",
                                            limits.peak(joints.q, rate, order), limit))
    margin = np.minimum(execution.q - arm.lower, arm.upper - execution.q)
    figures["reported_min_position_margin_rad"] = float(margin.min())
    figures["reported_torque_max"] = np.abs(execution.tau).max(axis=0).tolist()
    figures["duration_s"] = execution.duration
    figures["wall_s"] = execution.wall_s
    figures["real_time_factor"] = execution.duration / max(execution.wall_s, 1e-9)
    figures["cycles"] = int(len(execution.t))
    return figures
