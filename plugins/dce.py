"""Initialiser "dce": discrete curve evolution of each stroke to its salient points.

The declaration only (its options and a call that checks the job's inputs); the algorithm
— the relevance K = β·2·l1·l2/(l1 + l2), the canvas-relative stop threshold, the search
for a number of targets and the initial turning angles — is
:mod:`inkmotion.initialisers.dce`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.initialisers.dce import (
    BEND_ESTIMATE,
    BEND_ESTIMATES,
    DEFAULT_RELEVANCE,
    MAX_BEND,
    dce_plans,
)
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import Initialiser, JobInputs
    from inkmotion.sigma_lognormal.plan import MotorPlan


@dataclass
class DceOptions:
    """Options of the 'dce' initialiser. Spec version 2 placed targets by an absolute
    threshold of 1 px·rad and started every δ at 0, and versions up to 16 clamped the
    initial δ to the authors' quarter circle (``earlier``)."""

    relevance: float = param(DEFAULT_RELEVANCE, "Plan density: the authors' DCE relevance "
                             "(turning ° × l1·l2/(l1+l2) ÷ canvas size) a target must exceed; "
                             "the same plan at any canvas size.", minimum=0)
    threshold: float | None = param(None, "Absolute DCE threshold, px·rad (overrides "
                                    "--dce-relevance).", minimum=0, earlier={2: 1.0})
    bend: bool = param(True, "Start each δ at the trace's bend between targets (else 0).",
                       earlier={2: False})
    max_bend: float = param(math.degrees(MAX_BEND), "The largest turn an initial δ starts "
                            "at, degrees (the trace's bend is clamped to it; the fit's "
                            "--max-turn clamps δ from the first step on).", minimum=0,
                            maximum=180, earlier={16: 90.0})
    bend_estimate: str = param(BEND_ESTIMATE, "Which arc an initial δ starts at: 'peak' "
                               "(through the trace's largest deviation from the chord), "
                               "'fitted' (closest to the whole trace between the targets) "
                               "or 'between' (halfway; try it where a fit from a "
                               "picture draws an arch over a turn).",
                               choices=BEND_ESTIMATES)


class DceInitialiser:
    """One motor plan per stroke through the stroke's DCE salient points."""

    name = "dce"
    description = (
        "Discrete curve evolution: one motor plan per stroke through its salient points "
        "(relevance: turning angle × harmonic mean arm length; stop above `relevance`, "
        "relative to the canvas, or the absolute `threshold` in px·rad)."
    )
    Options = DceOptions

    def __call__(
        self,
        inputs: JobInputs,
        *,
        width: float = 3.0,
        dtype: Any = None,
        device: Any = None,
        relevance: float = DEFAULT_RELEVANCE,
        threshold: float | None = None,
        bend: bool = True,
        max_bend: float = math.degrees(MAX_BEND),
        bend_estimate: str = BEND_ESTIMATE,
    ) -> list[MotorPlan]:
        """Plans for every stroke of ``inputs.traces`` (validated first: degenerate strokes
        dropped); ``inputs.targets`` asks for about that many sub-movements in all
        (:func:`inkmotion.initialisers.dce.dce_plans`)."""
        if inputs.traces is None:
            raise SpecError("The dce initialiser needs traces (a drawing input); use another "
                            "initialiser for images or captions.")
        return dce_plans(inputs.traces.validated().strokes, max(inputs.canvas),
                         targets=inputs.targets, relevance=relevance, threshold=threshold,
                         bend=bend, max_bend=math.radians(max_bend),
                         bend_estimate=bend_estimate, width=width,
                         dtype=dtype, device=device)


@hookimpl
def inkmotion_initialisers() -> list[Initialiser]:
    return [DceInitialiser()]
