"""What a running job tells its observers: progress bars, the job store, rerun recordings.

A neutral module: the optimiser (``inkmotion.fitting``) emits these events and the job
shell (``inkmotion.jobs``) drives the observers, so neither imports the other.

The shell calls, in order: ``on_start(ctx)`` once, ``on_step(state)`` after every step,
and ``on_end(report)`` once the artifacts are complete (still in the staging directory).
Any method may be omitted.

Loss values travel as 0-d tensors, still on the job's device: reading one (``float()``)
waits for the device, so an observer reads them only on the steps it shows them (the
progress bar every few steps, the recording in batches) and the step loop itself never
synchronises with the GPU.

What the progress bar shows beside the step count is the kind's to say: an optimisation
leaves ``StepState.figures`` unset and the bar shows its loss terms and T_end; a kind that
optimises nothing (simulate, evaluate, plot, draw) sets ``figures`` to its own (the stage
it is in, the figures known so far), and the bar shows those and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol


@dataclass
class RunContext:
    """What an observer may need to know before the first step."""

    spec: Any  # the JobSpec
    staging_dir: Path  # artifacts are written here, then moved into place atomically
    total_steps: int  # steps the job will report
    canvas: tuple[int, int] = (0, 0)  # (width, height) px
    target: Any = None  # (H, W) target image tensor, ink = 1, when the kind has one
    traces: list = field(default_factory=list)  # input strokes in canvas px, (k, 2|3) arrays


@dataclass
class StepState:
    """The job's state after one step (tensors detached, possibly on the GPU)."""

    step: int  # 1-based
    total: int
    losses: dict[str, Any]  # every loss term and "total": 0-d tensors (or floats)
    t_end: Any  # mean T_end over paths: a 0-d tensor (or a float); None: the kind has none
    rendered: Any = None  # (H, W), only when asked for (see wants_image)
    positions: list = field(default_factory=list)  # per path (n_p, D)
    speeds: list = field(default_factory=list)  # per path (n_p,)
    targets: list = field(default_factory=list)  # virtual targets per path
    #: what the progress bar shows beside the count, in order: name → text, number or 0-d
    #: tensor (read only when shown); None: the loss terms and T_end (an optimisation)
    figures: dict[str, Any] | None = None

    def loss_values(self) -> dict[str, float]:
        """The loss terms as Python floats (one device synchronisation)."""
        return scalars(self.losses)

    def shown(self) -> dict[str, Any]:
        """What a progress display shows of this step: the kind's ``figures``, else the
        total loss, T_end (the mean over paths, so named: report.json's ``final_t_end`` is
        the drawing's total) and the loss terms (0-d tensors not read yet)."""
        if self.figures is not None:
            return dict(self.figures)
        terms = {k: v for k, v in self.losses.items() if k != "total"}
        total = {"loss": self.losses["total"]} if "total" in self.losses else {}
        return {**total, "T_end/path": self.t_end, **terms}


class Observer(Protocol):
    def on_start(self, ctx: RunContext) -> None: ...
    def on_step(self, state: StepState) -> None: ...
    def on_end(self, report: dict) -> None: ...


def wants(observer: object, what: str, step: int) -> bool:
    """True when ``observer`` asks for heavy data (``what`` = "image" or "geometry") at
    ``step``: observers define ``wants_image(step) -> bool`` / ``wants_geometry(step)``."""
    fn = getattr(observer, f"wants_{what}", None)
    return bool(fn(step)) if fn is not None else False


def scalars(values: dict[str, Any]) -> dict[str, float]:
    """``{name: float}`` from 0-d tensors or numbers, read from the device in one transfer."""
    names = list(values)
    tensors = [v for v in values.values() if hasattr(v, "detach")]
    if not tensors:
        return {k: float(v) for k, v in values.items()}
    import torch

    read = iter(torch.stack([t.detach().reshape(()).to(torch.float64) for t in tensors])
                .cpu().tolist())
    return {k: (next(read) if hasattr(values[k], "detach") else float(values[k]))
            for k in names}
