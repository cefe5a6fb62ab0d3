"""Job kind "draw": a real Franka (FR3 or Panda) draws a motor plan through libfranka.

The same setup, calibration, timing and joint planning as 'simulate', inside the connected
arm's own limits (retimed where the plan would exceed them); then, on the robot at
``--robot HOST``: connect (10 s), identify the model, check the arm's pose against the
plan's start, approach it, stream the drawing at 1 kHz under joint impedance (franky's
tracking controller), and come to rest at home. ``--dry-run`` connects and checks without
moving. Jobs go to the ``robot`` queue, so only the worker wired to the arm takes them.

Artifacts: joints.csv, cartesian.csv, setup.toml, executed.csv (the robot's reported states
at 1 kHz and the pen tip), plan_drawing.png, robot_drawing.png, side_by_side.png,
report.json, recording.rrd. The work is in :mod:`inkmotion.kinds.draw`, the robot's side in
:mod:`inkmotion.robot.franka`; importing this module imports neither franky nor torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.jobs.kind import InputSpec
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.kind import ResolvedJob
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import JobKind


@dataclass
class DrawParams:
    """Parameters of a drawing on a real arm (the bench itself is in the setup TOML)."""

    robot: str = param("", "Hostname or IP address of the robot's FCI (required).")
    setup: str = param("", "Setup TOML (plane, paper, pen, limits, home); empty: the shipped "
                       "default. Teach one with `inkmotion robot teach`.", file=True)
    v_max: float = param(0.0, "Pen speed limit, m/s (0: the setup's).", minimum=0, maximum=1.7)
    a_max: float = param(0.0, "Pen acceleration limit, m/s² (0: the setup's).", minimum=0,
                         maximum=13.0)
    dry_run: bool = param(False, "Connect, plan and check everything, do not move the arm.")
    realtime: str = param("enforce", "libfranka's real-time check: enforce (a real arm needs "
                          "a PREEMPT_RT kernel) or ignore (simulators and test benches only).",
                          choices=("enforce", "ignore"))
    model: str = param("auto", "The arm's model: auto (from the URDF the robot reports), fr3 "
                       "or panda.", choices=("auto", "fr3", "panda"))
    max_approach: float = param(0.5, "Largest joint distance (rad) from the plan's start pose "
                                "the arm may be moved across before drawing.", minimum=0,
                                maximum=3.0)
    approach_speed: float = param(0.1, "Fraction of the arm's velocity, acceleration and jerk "
                                  "limits for the approach move.", minimum=0.01, maximum=0.5)
    recover: bool = param(False, "After a reflex, clear the robot's errors automatically "
                          "(libfranka's automatic error recovery); the drawing is not resumed.")

    def validate(self) -> None:
        if not self.robot.strip():
            raise SpecError("The draw job needs the robot's address: --robot HOST (the FCI "
                            "hostname or IP, e.g. 172.16.0.2).")


class DrawKind:
    """The 'draw' job kind (see the module docstring)."""

    name = "draw"
    description = "A real Franka draws a plan through libfranka: 1 kHz joint impedance tracking."
    queue = "robot"
    inputs = (InputSpec("plan", "A plan.json written by a fit, tag or abstract job.",
                        form="file"),)
    Params = DrawParams
    examples = (
        "inkmotion run draw results/hello/plan.json --robot 172.16.0.2 --dry-run "
        "--out results/hello-dry",
        "inkmotion run draw results/hello/plan.json --robot 172.16.0.2 --setup bench.toml "
        "--out results/hello-arm",
        "inkmotion run draw plan.json --robot 127.0.0.1 --realtime ignore --max-approach 1.0 "
        "--out r/sim-arm   # franky-sim: its arm starts 0.8 rad from home",
        "inkmotion robot teach --robot 172.16.0.2 --out bench.toml   # the drawing plane",
    )

    def steps(self, params: DrawParams) -> int:
        return 6

    def check_inputs(self, job: ResolvedJob) -> None:
        """Refuse a plan.json or a setup file the run could not use (``inkmotion submit``
        asks first)."""
        from inkmotion.kinds.read import check_plan_input
        from inkmotion.kinds.simulate import job_setup

        check_plan_input(job)
        job_setup(job.params.setup, job.params.v_max, job.params.a_max)

    def run(self, job: Job) -> dict[str, Any]:
        from inkmotion.kinds.draw import run_draw

        return run_draw(job)


@hookimpl
def inkmotion_job_kinds() -> list[JobKind]:
    return [DrawKind()]
