"""The compound objective of a fit: λ·L_smooth + w_I·Σ L_I + w_c·canvas term.

One evaluation is the hot loop's forward pass: ΣΛ kinematics on the fitting grid
(n_p = samples_per_move·m_p) → Hermite Bézier segments → render → image losses, plus the
smoothing cost (DESIGN.md § Fitting defaults) and a term keeping targets on the canvas.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch

from inkmotion.errors import InkmotionError
from inkmotion.fitting.losses import canvas_cost, smoothing_cost
from inkmotion.geometry.bezier import hermite_segments
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.kinematics import batch_kinematics, uniform_times

Renderer = Callable[[torch.Tensor, torch.Tensor, int, int], torch.Tensor]
ImageLoss = Callable[[torch.Tensor], torch.Tensor]


@dataclass(frozen=True)
class Weights:
    """Weights of the compound objective (defaults: DESIGN.md, λ tuned to 20)."""

    lambda_smooth: float = 20.0
    w_image: float = 200.0
    w_sigma: float = 50.0
    w_canvas: float = 1.0
    samples_per_move: int = 5


@dataclass
class Evaluation:
    """One forward pass: the loss terms and what the observers may want to see."""

    total: torch.Tensor
    terms: dict[str, torch.Tensor]
    t_end: torch.Tensor  # (P,)
    rendered: torch.Tensor  # (H, W)
    positions: torch.Tensor  # (N, D)
    velocities: torch.Tensor  # (N, D)
    counts: torch.Tensor  # (P,)


class Objective:
    """λ·mean_p(T_end/m + w_σ·VarΔt) + w_I·Σ image losses + w_c·canvas term."""

    def __init__(self, renderer: Renderer, image_losses: dict[str, ImageLoss],
                 canvas: tuple[int, int], weights: Weights) -> None:
        self.renderer = renderer
        self.image_losses = image_losses
        self.width, self.height = canvas
        self.p = weights

    def __call__(self, batch: PlanBatch) -> Evaluation:
        times, counts, dt = uniform_times(batch, self.p.samples_per_move)
        t_end = times[torch.cumsum(counts, 0) - 1]  # (P,) the last sample is T_end
        kin = batch_kinematics(batch, times, counts)
        segments, seg_path = hermite_segments(kin.positions, kin.velocities, counts, dt)
        widths = batch.widths[seg_path]
        try:
            rendered = self.renderer(segments[..., :2].contiguous(), widths, self.height,
                                     self.width)
        except ValueError as exc:  # e.g. NaN coordinates after a diverging step
            raise InkmotionError(f"The renderer refused the trajectory ({exc}); lower the "
                                 "learning rates or check the input.") from exc
        terms: dict[str, torch.Tensor] = {}
        image = rendered.new_zeros(())
        for name, fn in self.image_losses.items():
            terms[name] = fn(rendered)
            image = image + terms[name]
        terms["smooth"] = smoothing_cost(batch, t_end, self.p.w_sigma)
        terms["canvas"] = canvas_cost(batch.points, self.width, self.height)
        total = (self.p.lambda_smooth * terms["smooth"] + self.p.w_image * image
                 + self.p.w_canvas * terms["canvas"])
        if not torch.isfinite(total):
            raise InkmotionError(
                "The optimisation produced a non-finite loss (NaN); lower the learning rates "
                "or check the input for extreme coordinates."
            )
        return Evaluation(total, terms, t_end, rendered, kin.positions, kin.velocities, counts)
