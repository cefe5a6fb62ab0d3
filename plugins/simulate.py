"""Job kind "simulate": a Franka Panda draws a motor plan (the paper's "Executing ΣΛ
trajectories with a robot").

plan.json (canvas px) → the paper rectangle on a drawing plane calibrated from four taught
points (setup TOML) → uniform time scaling of the ΣΛ trajectory to v_max and a_max, resampled
at the control rate, with pen-up transfers → a joint trajectory by Gauss–Newton on
Pinocchio's Panda (pen tip tracked, pen normal to the plane, joint limits with margin) →
each robot backend: 'franka-sim' executes it in MuJoCo at 1 kHz with a joint impedance
controller, 'export' writes it for a real controller.

Artifacts: joints.csv, cartesian.csv, setup.toml (as used), the backends' files
(franka-sim: executed.csv, sim_drawing.png, side_by_side.png; export: export/...), plus
job.json, report.json and recording.rrd (the execution replayed on a time timeline).
The work is in :mod:`inkmotion.kinds.simulate` (the robot engine in :mod:`inkmotion.robot`);
importing this module imports no torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.jobs.kind import InputSpec
from inkmotion.jobs.params import PluginChoice, param, plugin_param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.kind import ResolvedJob
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import JobKind


@dataclass
class SimulateParams:
    """Parameters of a robot run (most settings live in the setup TOML)."""

    setup: str = param("", "Setup TOML (plane, paper, pen, limits, home); empty: the shipped "
                       "default (inkmotion.robot/default_setup.toml).", file=True)
    v_max: float = param(0.0, "Pen speed limit, m/s (0: the setup's).", minimum=0, maximum=1.7)
    a_max: float = param(0.0, "Pen acceleration limit, m/s² (0: the setup's).", minimum=0,
                         maximum=13.0)
    backends: list[PluginChoice] = plugin_param("robot-backend", "franka-sim",
                                                "Robot backend (repeatable).", many=True,
                                                flag="--backend")

    def validate(self) -> None:
        if not self.backends:
            raise SpecError("The simulate job needs a robot backend (--backend franka-sim or "
                            "--backend export).")


class SimulateKind:
    """The 'simulate' job kind (see the module docstring)."""

    name = "simulate"
    description = "A Franka Panda draws a plan: calibrated plane, timing, joint trajectory, MuJoCo."
    queue = "simulate"
    inputs = (InputSpec("plan", "A plan.json written by a fit, tag or abstract job.",
                        form="file"),)
    Params = SimulateParams
    examples = (
        "inkmotion run simulate results/hello/plan.json --out results/hello-robot",
        "inkmotion run simulate plan.json --setup my_table.toml --v-max 0.25 --out r/sim",
        "inkmotion run simulate plan.json --backend export --export-rate 500 --out r/export",
        "inkmotion view results/hello-robot   # the arm drawing, on a time timeline",
    )

    def steps(self, params: SimulateParams) -> int:
        return 2 + len(params.backends)  # timing, joints, one per backend

    def check_inputs(self, job: ResolvedJob) -> None:
        """Refuse a plan.json or a setup file the run could not use (``inkmotion submit``
        asks first)."""
        from inkmotion.kinds.read import check_plan_input
        from inkmotion.kinds.simulate import job_setup

        check_plan_input(job)
        job_setup(job.params.setup, job.params.v_max, job.params.a_max)

    def run(self, job: Job) -> dict[str, Any]:
        from inkmotion.kinds.simulate import run_simulate

        return run_simulate(job)


@hookimpl
def inkmotion_job_kinds() -> list[JobKind]:
    return [SimulateKind()]
