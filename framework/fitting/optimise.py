"""The optimiser loop: Adam on the motor plans through the differentiable renderer.

Each step: ΣΛ kinematics on the fitting grid (n_p = 5·m_p) → Hermite Bézier segments →
render → image losses; plus λ·L_smooth and the canvas term. Then an Adam step with
per-parameter learning rates and a cosine decay, and the clamps Δt ∈ [0.1, 0.9],
δ ∈ [−π/2, π/2], Ac ∈ [1e-4, 0.1] (DESIGN.md § Fitting defaults).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import torch

from inkmotion.errors import InkmotionError
from inkmotion.fitting.losses import canvas_cost, smoothing_cost
from inkmotion.geometry.bezier import hermite_segments
from inkmotion.jobs.observers import Observer, StepState, wants
from inkmotion.jobs.spec import FitParams
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.kinematics import batch_kinematics, uniform_times
from inkmotion.sigma_lognormal.plan import MotorPlan

DELTA_T_RANGE = (0.1, 0.9)
DELTA_RANGE = (-math.pi / 2, math.pi / 2)
AC_RANGE = (1e-4, 0.1)

Renderer = Callable[[torch.Tensor, torch.Tensor, int, int], torch.Tensor]
ImageLoss = Callable[[torch.Tensor], torch.Tensor]


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


@dataclass
class FitResult:
    plans: list[MotorPlan]
    initial_terms: dict[str, float]
    final_terms: dict[str, float]
    initial_t_end: list[float]
    final_t_end: list[float]
    rendered: torch.Tensor  # (H, W) final
    wall_s: float
    steps: int
    history: list[dict[str, float]] = field(default_factory=list)


class Objective:
    """λ·mean_p(T_end/m + w_σ·VarΔt) + w_I·Σ image losses + w_c·canvas term."""

    def __init__(self, renderer: Renderer, image_losses: dict[str, ImageLoss],
                 canvas: tuple[int, int], params: FitParams) -> None:
        self.renderer = renderer
        self.image_losses = image_losses
        self.width, self.height = canvas
        self.p = params

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


def _cosine(step: int, total: int, final: float) -> float:
    """Learning-rate factor: cosine decay from 1 to ``final`` over ``total`` steps."""
    return final + (1.0 - final) * 0.5 * (1.0 + math.cos(math.pi * min(step, total) / total))


def _floats(terms: dict[str, torch.Tensor], total: torch.Tensor) -> dict[str, float]:
    out = {k: float(v.detach()) for k, v in terms.items()}
    out["total"] = float(total.detach())
    return out


def _state(step: int, total: int, ev: Evaluation, batch: PlanBatch, observers: Sequence[Observer],
           terms: dict[str, float]) -> StepState:
    state = StepState(step, total, terms, float(ev.t_end.detach().mean()))
    if any(wants(o, "image", step) for o in observers):
        state.rendered = ev.rendered.detach()
    if any(wants(o, "geometry", step) for o in observers):
        counts = ev.counts.tolist()
        state.positions = list(torch.split(ev.positions.detach(), counts))
        state.speeds = list(torch.split(ev.velocities.detach()[:, :2].norm(dim=1), counts))
        state.targets = list(torch.split(batch.points.detach(), (batch.moves + 1).tolist()))
    return state


def optimise(
    plans: list[MotorPlan],
    objective: Objective,
    params: FitParams,
    observers: Sequence[Observer] = (),
    progress: Callable[[int, dict[str, float], float], None] | None = None,
) -> FitResult:
    """Fit ``plans`` for ``params.steps`` Adam steps; returns the final (detached) plans."""
    start = time.perf_counter()
    src = PlanBatch.from_plans([p.detached() for p in plans])
    leaves = {k: getattr(src, k).clone().requires_grad_(True)
              for k in ("points", "delta_t", "delta", "ac")}
    batch = PlanBatch(leaves["points"], leaves["delta_t"], leaves["delta"], leaves["ac"],
                      src.T, src.moves, src.widths)
    groups = [
        {"params": [leaves["points"]], "lr": params.lr_points},
        {"params": [leaves["delta_t"]], "lr": params.lr_delta_t},
        {"params": [leaves["delta"]], "lr": params.lr_delta},
    ]
    if params.lr_ac > 0:
        groups.append({"params": [leaves["ac"]], "lr": params.lr_ac})
    optimiser = torch.optim.Adam(groups)
    scheduler = torch.optim.lr_scheduler.LambdaLR(
        optimiser, lambda k: _cosine(k, params.steps, params.lr_final))

    with torch.no_grad():
        first = objective(batch)
    initial_terms = _floats(first.terms, first.total)
    initial_t_end = first.t_end.tolist()
    history: list[dict[str, float]] = []
    ev = first
    for step in range(1, params.steps + 1):
        optimiser.zero_grad(set_to_none=True)
        ev = objective(batch)
        ev.total.backward()
        optimiser.step()
        scheduler.step()
        with torch.no_grad():
            leaves["delta_t"].clamp_(*DELTA_T_RANGE)
            leaves["delta"].clamp_(*DELTA_RANGE)
            leaves["ac"].clamp_(*AC_RANGE)
        terms = _floats(ev.terms, ev.total)
        terms["t_end"] = float(ev.t_end.detach().sum())
        history.append(terms)
        if observers:
            state = _state(step, params.steps, ev, batch, observers, terms)
            for o in observers:
                if hasattr(o, "on_step"):
                    o.on_step(state)
        if progress is not None:
            progress(step, terms, float(ev.t_end.detach().sum()))

    with torch.no_grad():
        last = objective(batch)
    result_plans = PlanBatch(*(t.detach().clone() for t in (
        batch.points, batch.delta_t, batch.delta, batch.ac, batch.T)), src.moves,
        src.widths).to_plans()
    return FitResult(
        plans=result_plans,
        initial_terms=initial_terms,
        final_terms=_floats(last.terms, last.total),
        initial_t_end=initial_t_end,
        final_t_end=last.t_end.tolist(),
        rendered=last.rendered.detach(),
        wall_s=time.perf_counter() - start,
        steps=params.steps,
        history=history,
    )
