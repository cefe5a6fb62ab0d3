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

from inkmotion.fitting.objective import Evaluation, Objective
from inkmotion.jobs.observers import Observer, StepState, wants
from inkmotion.jobs.spec import FitParams
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.plan import MotorPlan

DELTA_T_RANGE = (0.1, 0.9)
DELTA_RANGE = (-math.pi / 2, math.pi / 2)
AC_RANGE = (1e-4, 0.1)



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
