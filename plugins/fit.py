"""Job kind "fit": a ΣΛ motion fitted to a drawing — a GML/JSON tag, an SVG or a word in a
Hershey font. The declaration; the work is :mod:`inkmotion.kinds.fit`.

Importing this module imports no torch (the command line lists kinds at once).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from inkmotion.jobs.kind import InputSpec
from inkmotion.kinds.fit import FitParams
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.kind import ResolvedJob
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import JobKind


class FitKind:
    """The 'fit' job kind (:mod:`inkmotion.kinds.fit`)."""

    name = "fit"
    description = ("Fit a ΣΛ motion to a drawing: a GML/JSON tag, an SVG, text:WORD or a "
                   "picture of line art (PNG, JPEG, ...).")
    queue = "optimise"
    inputs = (InputSpec("drawing", "A GML/JSON/SVG file, a picture of line art (PNG, JPEG, "
                                 "...; traced first, see `inkmotion trace`), sample:NAME "
                                 "(`inkmotion samples`) or text:WORD."),)
    Params = FitParams
    examples = (
        "inkmotion run fit text:hello --out results/hello",
        "inkmotion run fit sample:tempt-1 --out results/tag --steps 300",
        "inkmotion run fit my_drawing.jpg --out results/picture --varying-width",
        "inkmotion run fit my_tag.gml --out results/smoother --lambda 150 --size 500",
        "inkmotion run fit sample:tempt-3 --out results/sparse --dce-relevance 5",
        "inkmotion run fit sample:tempt-3 --out results/twenty --targets 20",
        "inkmotion run fit sample:spiral --out results/auto --targets auto --max-error 1.5",
    )

    def steps(self, params: FitParams) -> int:
        return params.steps

    def check_inputs(self, job: ResolvedJob) -> None:
        """Refuse a drawing the fit could not read (``inkmotion submit`` asks first)."""
        from inkmotion.kinds.fit import check_inputs

        check_inputs(job)

    def warm_up(self) -> None:
        """Import what a fit imports while it runs (:func:`inkmotion.kinds.fit.warm_up`)."""
        from inkmotion.kinds import fit

        fit.warm_up()

    def run(self, job: Job) -> dict[str, Any]:
        from inkmotion.kinds import fit

        return fit.run(job)

    def run_together(self, jobs: list[Job]) -> list[dict[str, Any] | BaseException]:
        """Several fits as one batched optimisation (:func:`inkmotion.kinds.fit.run_together`)."""
        from inkmotion.kinds import fit

        return fit.run_together(jobs)


@hookimpl
def inkmotion_job_kinds() -> list[JobKind]:
    return [FitKind()]
