"""Initialiser "line": the start of a tag generated from a caption alone.

A zig-zag of ``targets`` sub-movements (the option, else the job's ``targets``, else 30)
across ``extent`` of the canvas width, ± ``amplitude`` of the canvas height about its
centre line, with the initialisation defaults (Δt = 1, δ = 0): the paper's "initial
trajectory with Δt = 1" (Fig. 4a). Why a zig-zag and these defaults:
:mod:`inkmotion.initialisers.line`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.initialisers.line import DEFAULT_AMPLITUDE, DEFAULT_EXTENT, DEFAULT_TARGETS
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import Initialiser, JobInputs
    from inkmotion.sigma_lognormal.plan import MotorPlan


@dataclass
class LineOptions:
    """Options of the 'line' initialiser."""

    targets: int | None = param(None, "Sub-movements, i.e. targets after the start "
                                "(default: the job's targets, else 30).",
                                minimum=1, maximum=10_000)
    extent: float = param(DEFAULT_EXTENT, "Fraction of the canvas width the line spans.",
                          minimum=0.01, maximum=1.0)
    amplitude: float = param(DEFAULT_AMPLITUDE, "Half height of the zig-zag, fraction of "
                             "the canvas height (0: a straight line).", minimum=0.0,
                             maximum=0.5)


class LineInitialiser:
    """One zig-zag motor plan across the canvas, for inputs with no trace."""

    name = "line"
    description = ("One plan along the canvas's centre line: a zig-zag of `targets` "
                   "sub-movements over `extent` of the width, ± `amplitude` of the height "
                   "(Δt = 1, δ = 0), the start of a caption-only tag.")
    Options = LineOptions

    def __call__(self, inputs: JobInputs, *, width: float = 3.0, dtype: Any = None,
                 device: Any = None, targets: int | None = None,
                 extent: float = DEFAULT_EXTENT,
                 amplitude: float = DEFAULT_AMPLITUDE) -> list[MotorPlan]:
        """One plan centred on ``inputs.canvas``; ``targets`` None: ``inputs.targets``, else
        30. The other inputs are not used."""
        import torch

        from inkmotion.initialisers.line import zigzag
        from inkmotion.sigma_lognormal.plan import MotorPlan

        m = targets if targets is not None else inputs.targets or DEFAULT_TARGETS
        if m < 1:
            raise SpecError(f"The line initialiser needs at least 1 sub-movement, not {m}.")
        points = zigzag(inputs.canvas, m, extent, amplitude)
        return [MotorPlan.from_points(points, width=width, dtype=dtype or torch.float32,
                                      device=device)]


@hookimpl
def inkmotion_initialisers() -> list[Initialiser]:
    return [LineInitialiser()]
