"""Observers watch a running job: progress bars, the job store, rerun recordings.

The runner calls, in order: ``on_start(ctx)`` once, ``on_step(state)`` after every
optimiser step, and ``on_end(report)`` once the artifacts are complete (still in the
staging directory). Any method may be omitted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import torch


@dataclass
class RunContext:
    """What an observer may need to know before the first step."""

    spec: Any  # JobSpec
    staging_dir: Path  # artifacts are written here, then moved into place atomically
    canvas: tuple[int, int]  # (width, height) px
    target: torch.Tensor  # (H, W) target image, ink = 1
    traces: list  # input strokes in canvas px, list of (k, 2|3) arrays
    n_paths: int
    n_moves: int


@dataclass
class StepState:
    """The optimiser's state after one step (tensors detached)."""

    step: int  # 1-based
    total: int
    losses: dict[str, float]  # every loss term and the total
    t_end: float  # mean T_end over paths
    rendered: torch.Tensor | None = None  # (H, W), only when asked for (see wants_image)
    positions: list[torch.Tensor] = field(default_factory=list)  # per path (n_p, D)
    speeds: list[torch.Tensor] = field(default_factory=list)  # per path (n_p,)
    targets: list[torch.Tensor] = field(default_factory=list)  # virtual targets per path


class Observer(Protocol):
    def on_start(self, ctx: RunContext) -> None: ...
    def on_step(self, state: StepState) -> None: ...
    def on_end(self, report: dict) -> None: ...


def wants(observer: object, what: str, step: int) -> bool:
    """True when ``observer`` asks for heavy data (``what`` = "image" or "geometry") at
    ``step``: observers define ``wants_image(step) -> bool`` / ``wants_geometry(step)``."""
    fn = getattr(observer, f"wants_{what}", None)
    return bool(fn(step)) if fn is not None else False
