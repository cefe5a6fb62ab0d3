"""A fit-sized problem (162 lognormals, a 350-px canvas) to profile one optimiser step with:
the forward pass of the :class:`~inkmotion.fitting.objective.Objective` (kinematics →
Bézier → raster → multi-scale MSE + smoothing cost) and its backward pass."""

from __future__ import annotations

import math

import torch

from inkmotion.fitting.objective import Evaluation, Objective, Weights
from inkmotion.profiling.host_syncs import HostSyncLog, count_host_syncs
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.plan import MotorPlan

#: sub-movements per path of the default problem: 162 in all, like a tag of the paper
MOVES = (40, 50, 72)
CANVAS = 350
#: the problem's objective weights: the authors' (λ = 20, w_σ = 50, per-path smoothing),
#: fixed here so the profiled step stays the same problem whatever a job kind's defaults
WEIGHTS = Weights(lambda_smooth=20.0, w_image=200.0, w_sigma=50.0, w_canvas=1.0,
                  samples_per_move=5, smooth_over="path", w_trace=0.0, w_floor=0.0)


def synthetic_plans(moves: tuple[int, ...] = MOVES, size: int = CANVAS, seed: int = 0,
                    device: torch.device | str = "cpu") -> list[MotorPlan]:
    """One wavy left-to-right stroke per entry of ``moves``, stacked down the canvas, with
    targets every few px (jittered) and the initialisation defaults (Δt = 1, δ = 0)."""
    g = torch.Generator().manual_seed(seed)
    plans = []
    for k, m in enumerate(moves):
        u = torch.linspace(0, 1, m + 1)  # (m+1,)
        row = size * (k + 1) / (len(moves) + 1)
        pts = torch.stack((0.15 * size + 0.7 * size * u,
                           row + 0.08 * size * torch.sin(2 * math.pi * 3 * u + k)), 1)
        pts = pts + torch.randn(m + 1, 2, generator=g)
        plans.append(MotorPlan.from_points(pts, device=device))
    return plans


def fit_problem(device: torch.device | str = "cpu", moves: tuple[int, ...] = MOVES,
                static: bool | None = None, check_every: int = 0) -> tuple[Objective, PlanBatch]:
    """An objective (raster renderer, multi-scale MSE against the targets' polylines) and a
    batch whose points, Δt and δ require grad, as the optimiser holds them.

    The renderer is the raster engine's :class:`~inkmotion.rendering.raster.RasterSession`
    set up as the 'raster' plugin's ``session`` sets it up for a fit, so the figures are the
    plugin's without the profiler reaching up to the plugins."""
    from inkmotion.image_losses.multiscale_mse import prepare_multiscale_mse
    from inkmotion.rendering.raster import RasterSession, render_segments

    src = PlanBatch.from_plans(synthetic_plans(moves, device=device))
    # the session the 'raster' plugin gives a fit: static budgets off the CPU unless told
    # otherwise, no value checks
    session_static = static if static is not None else src.points.device.type != "cpu"
    renderer = RasterSession(static=session_static, check=False)
    with torch.no_grad():
        a, b = src.points[:-1], src.points[1:]
        lines = torch.stack((a, a + (b - a) / 3, a + 2 * (b - a) / 3, b), 1)  # (., 4, 2)
        target = render_segments(lines, 3.0, CANVAS, CANVAS)
    objective = Objective(renderer, {"mse": prepare_multiscale_mse(target)}, (CANVAS, CANVAS),
                          WEIGHTS, static=static, check_every=check_every)
    leaves = [t.clone().requires_grad_(True) for t in (src.points, src.delta_t, src.delta)]
    return objective, PlanBatch(*leaves, src.ac, src.T, src.moves, src.widths)


def step(objective: Objective, batch: PlanBatch) -> Evaluation:
    """One forward and backward pass (gradients of the batch's leaves cleared first)."""
    for t in (batch.points, batch.delta_t, batch.delta):
        t.grad = None
    ev = objective(batch)
    ev.total.backward()
    return ev


def step_host_syncs(objective: Objective, batch: PlanBatch) -> HostSyncLog:
    """The host synchronisations of one :func:`step` (after a first, planning, step)."""
    step(objective, batch)
    with count_host_syncs() as log:
        step(objective, batch)
    return log
