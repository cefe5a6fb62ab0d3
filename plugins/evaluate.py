"""Job kind "evaluate": the paper's evaluation of a ΣΛ motion (section "Evaluation", the
table of its last figure). One path of a plan, three timings of the same geometry under the
same v_max / a_max — ΣΛ (the plan's own timing, uniformly time-scaled to the limits), the
path-constrained minimum-jerk timing (Todorov & Jordan 1998) time-scaled to the limits, and
the time-optimal timing (TOPP-RA, standing in for Kunz & Stilman's TOTG) — compared by
duration, mean squared jerk (MSJ) and log dimensionless jerk (LDJ), as ratios method/ΣΛ
(> 1: ΣΛ is better). With ``--recording`` (the GML the plan was fitted to, when it carries
time stamps) also the agreement of the fit's speed peaks with the human's.

Artifacts: evaluation.json, evaluation.csv, speeds.png (the three speed profiles on one
time axis), minima.png (speed minima colour-coded along the path, the paper's Fig. 3c/d),
human_speeds.png (with a recording), job.json, report.json. Implementation:
:mod:`inkmotion.kinds.evaluate` (the comparison itself in
:mod:`inkmotion.evaluation.comparison`); importing this module imports no torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.jobs.kind import InputSpec
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.kind import ResolvedJob
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import JobKind


@dataclass
class EvaluateParams:
    """Parameters of an evaluation (limits in the robot's units, as in the setup TOML)."""

    v_max: float = param(0.25, "Pen speed limit, m/s.", minimum=1e-4, maximum=1.7,
                         flag="--vmax")
    a_max: float = param(2.5, "Pen acceleration limit, m/s².", minimum=1e-4, maximum=13.0,
                         flag="--amax")
    path: int = param(-1, "Which path of the plan (0-based); -1: every path, per path and "
                      "over the drawing (the plots show the longest).", minimum=-1)
    rate: float = param(1000.0, "Sampling rate of the timings, Hz.", minimum=50,
                        maximum=10_000)
    setup: str = param("", "Robot setup TOML whose paper maps px to metres (empty: default).",
                       file=True)
    recording: str = param("", "The GML/JSON the plan was fitted to, for the agreement with "
                           "its recorded speed (when it has time stamps).", file=True)
    recording_time_unit: str = param("auto", "The unit of the recording's time stamps: 's', "
                                     "'ms' or 'auto' (told by their step).",
                                     choices=("auto", "s", "ms"))


class EvaluateKind:
    """The 'evaluate' job kind (see the module docstring)."""

    name = "evaluate"
    description = "Compare ΣΛ with minimum-jerk and time-optimal timings of the same path."
    queue = "optimise"
    inputs = (InputSpec("plan", "A plan.json written by a fit, tag or abstract job.",
                        form="file"),)
    Params = EvaluateParams
    examples = (
        "inkmotion evaluate results/tag/plan.json --out results/tag-eval",
        "inkmotion evaluate results/tag/plan.json --vmax 0.5 --amax 5 --path 2 --out results/e2",
        "inkmotion evaluate results/tag/plan.json --recording sample:tempt-1 --out results/e3"
        "  # + human agreement",
    )

    def steps(self, params: EvaluateParams) -> int:
        return 4  # one per timing (of each path; the job says how many paths it times)

    def check_inputs(self, job: ResolvedJob) -> None:
        """Refuse a plan.json the run could not read (``inkmotion submit`` asks first)."""
        from inkmotion.kinds.read import check_plan_input

        check_plan_input(job)

    def run(self, job: Job) -> dict[str, Any]:
        from inkmotion.kinds.evaluate import run_evaluate

        return run_evaluate(job)


@hookimpl
def inkmotion_job_kinds() -> list[JobKind]:
    return [EvaluateKind()]
