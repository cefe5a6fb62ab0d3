"""The 'simulate' job kind's work: setup → robot program (timing, joint trajectory) →
every chosen robot backend.

Stages are reported as steps (1: timing, 2: joint trajectory, then one per backend), so
the progress bar and the job store follow a long simulation; the bar shows the stage
running and the figures known so far (the drawing's duration, the tracking error of
each simulated arm). Everything that can refuse
the job (setup file, plan file, reachability) runs before any motion is planned in full;
nothing is written until the plan is known to be feasible. The backends are the job's
``robot-backend`` plugins, looked up here and handed the program: the robot engine never
sees the plugin host.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from inkmotion.events import StepState

if TYPE_CHECKING:
    from inkmotion.jobs.shell import Job
    from inkmotion.robot.setup import RobotSetup
    from inkmotion.robot.types import RobotProgram


def job_setup(setup_path: str, v_max: float, a_max: float) -> RobotSetup:
    """The setup file (or the shipped default) with the job's speed limits when given
    (0: the setup's own)."""
    from inkmotion.robot.setup import load_setup

    overrides: dict[str, Any] = {}
    if v_max > 0:
        overrides["v_max"] = v_max
    if a_max > 0:
        overrides["a_max"] = a_max
    return load_setup(setup_path or None, overrides or None)


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
    """Load the plan and the setup, plan the robot program, run every backend; the report
    holds the timing, the joint trajectory's figures, the setup and each backend's figures."""
    from inkmotion.robot.program import plan_program
    from inkmotion.sigma_lognormal import Drawing

    p = job.params
    drawing = Drawing.load(job.input_file("plan"))
    setup = job_setup(p.setup, p.v_max, p.a_max)
    job.start((int(drawing.canvas[0]), int(drawing.canvas[1])))
    total = job.total_steps
    names = [choice.name for choice in p.backends]

    def stage(step: int, figures: dict[str, Any]) -> None:
        """Stage ``step`` is done (1 timing, 2 joints, then one per backend); ``figures``:
        what the progress bar shows until the next."""
        job.observers.on_step(StepState(step, total, {}, None, figures=figures))

    def planned(step: int, name: str) -> None:
        if step == 1:  # stage 2 is reported below, with the figures of the planned program
            stage(1, {"now": "joint trajectory"})

    program = plan_program(drawing, setup, on_stage=planned)
    write_program(job.folder, program)
    report = program_report(program)
    metrics = {"duration_s": report["duration_s"],
               "ik_max_position_error_mm": report["joint_trajectory"]["max_position_error_mm"]}
    shown: dict[str, Any] = {"duration_s": metrics["duration_s"]}
    stage(2, {"now": names[0], **shown})
    for i, choice in enumerate(p.backends, start=3):
        backend = job.plugin(choice)
        figures = backend.execute(program, job.folder, **job.options(choice))
        stream = job.recording_stream()
        replay = getattr(backend, "replay", None)
        if stream is not None and replay is not None:
            replay(program, figures, stream)
        figures = {k: v for k, v in figures.items() if not k.startswith("_")}
        report[choice.name] = figures
        metrics.update(figures.get("metrics", {}))
        if "tracking_down_plane_rms_mm" in figures:
            shown["tracking_rms_mm"] = figures["tracking_down_plane_rms_mm"]
        following = names[i - 2:i - 1]
        stage(i, {**({"now": following[0]} if following else {}), **shown})
    report["metrics"] = metrics
    said = [w for choice in p.backends for w in execution_warnings(choice.name,
                                                                    report[choice.name])]
    if said:
        report["warnings"] = [*report.get("warnings", []), *said]
    return report


#: mm: a simulated pen that strays further than this from the plan while it draws is
#: reported (the default bench tracks within about 0.3 mm)
STRAY_MM = 2.0


def execution_warnings(backend: str, figures: dict[str, Any]) -> list[str]:
    """One sentence per way an executed drawing went wrong that its figures show: the pen
    far off the plan while drawing, or the arm past its velocity, acceleration or jerk
    limits (a margin below 0). A run that ends "done" must not hide either."""
    said = []
    off = figures.get("tracking_down_plane_max_mm")
    if isinstance(off, (int, float)) and off > STRAY_MM:
        said.append(f"{backend}: the pen drew up to {off:.1f} mm off the plan (RMS "
                    f"{figures.get('tracking_down_plane_rms_mm', float('nan')):.1f} mm, "
                    f"press up to {figures.get('contact_force_max_n', float('nan')):.0f} N); "
                    "press less (the setup's contact_offset nearer 0) or slow it down "
                    "(v_max, a_max).")
    over = [name for name in ("velocity", "acceleration", "jerk")
            if isinstance(figures.get(f"executed_joint_{name}_min_margin"), (int, float))
            and figures[f"executed_joint_{name}_min_margin"] < 0.0]
    if over:
        worst = min(figures[f"executed_joint_{name}_min_margin"] for name in over)
        said.append(f"{backend}: the executed joints went past the arm's {' and '.join(over)} "
                    f"limit (by {-100 * worst:.0f} % at worst), where a real arm stops with a "
                    "reflex; lower v_max and a_max, or press less.")
    return said


def program_report(program: RobotProgram) -> dict[str, Any]:
    """The report keys of a planned robot program (timing, joint trajectory, planning and
    limits, setup, plan size), shared by every kind that drives an arm."""
    cart, joints, setup, drawing = (program.cartesian, program.joints, program.setup,
                                    program.drawing)
    return {
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
        **_off_the_paper(cart.info.get("outside_paper_m")),
    }


#: m: a plan that reaches further than this beyond the paper is reported
OFF_PAPER_M = 1e-4


def _off_the_paper(outside: Any) -> dict[str, Any]:
    """The warning of a plan whose strokes leave its own canvas, so the pen leaves the
    paper (an edited plan.json, or one whose canvas was cut), or nothing."""
    if not isinstance(outside, (int, float)) or outside <= OFF_PAPER_M:
        return {}
    return {"warnings": [f"the plan's strokes leave its canvas, so the pen draws up to "
                         f"{1e3 * outside:.0f} mm beyond the paper; give the plan a canvas "
                         "that holds its strokes (fit it again), or a larger paper."]}
