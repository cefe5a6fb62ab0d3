"""What a plugin object of each kind looks like (structural typing, no base class needed)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    import torch

    from inkmotion.geometry.traces import Traces
    from inkmotion.sigma_lognormal.plan import MotorPlan


@runtime_checkable
class Plugin(Protocol):
    name: str
    description: str


class Reader(Plugin, Protocol):
    def can_read(self, source: str) -> bool:
        """True when this reader understands ``source`` (a path or ``scheme:value``)."""

    def read(self, source: str) -> Traces:
        """Parse ``source``; raise :class:`inkmotion.errors.InputError` on bad input."""


class Initialiser(Plugin, Protocol):
    def __call__(self, traces: Traces, **params: Any) -> list[MotorPlan]:
        """Make one motor plan per trajectory (pen lift between plans)."""


class ImageLoss(Plugin, Protocol):
    def prepare(self, target: torch.Tensor, **params: Any) -> Any:
        """Return a callable ``loss(rendered (H, W)) -> scalar`` bound to ``target``."""


class Renderer(Plugin, Protocol):
    def __call__(
        self, segments: torch.Tensor, widths: torch.Tensor, height: int, width: int
    ) -> torch.Tensor:
        """Render cubic segments (S, 4, 2) with widths (S,) to coverage (H, W) in [0, 1]."""
