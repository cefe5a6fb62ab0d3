"""The fit step's hand-written graph nodes: the sub-movement terms, the grid's timing and the
overlaps' floor barrier each compute the forward with the plain ops (the same values) and
write their gradient out. Each gradient is checked in float64 against finite differences
(``gradcheck``) and against autograd's graph of the plain ops, over the cases that make
them hard: δ at and near 0 (sinc's slope), samples before a window opens (φ's floor),
3-D plans, paths of one sub-movement, shapes Ac that differ (the peaks' side of the
barrier's minimum) and that agree (a tie)."""

from __future__ import annotations

import math

import pytest
import torch

from inkmotion.fitting.losses import _FloorBarrier, _gap_parts, floor_barrier
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.kinematics import (
    _GridTiming,
    _SubmovementTerms,
    _terms,
    grid_timing,
    submovement_terms,
    uniform_times,
)
from inkmotion.sigma_lognormal.plan import MotorPlan

F64 = torch.float64


def _relative(ours: tuple[torch.Tensor, ...], theirs: tuple[torch.Tensor, ...]) -> float:
    return max(float((a - b).abs().max() / b.abs().max().clamp(min=1e-300))
               for a, b in zip(ours, theirs, strict=True))


def _term_inputs(dim: int, deltas: list[float], device: torch.device) -> list[torch.Tensor]:
    g = torch.Generator().manual_seed(dim + len(deltas))
    m, k = len(deltas), 6
    tau = torch.rand(m, k, generator=g, dtype=F64) * 0.8 - 0.05  # some before the opening
    d = torch.randn(m, dim, generator=g, dtype=F64) * 30
    sigma = 0.1 + 0.3 * torch.rand(m, generator=g, dtype=F64)
    mu = -1.5 + torch.rand(m, generator=g, dtype=F64)
    delta = torch.tensor(deltas, dtype=F64)
    return [t.to(device).requires_grad_(True) for t in (tau, d, delta, sigma, mu)]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("deltas", [[0.0, 0.0, 0.0], [1e-9, -1e-6, 1e-3, 0.05, -0.2],
                                    [-2.5, -1.0, 0.7, 2.9]])
def test_the_submovement_terms_gradient(dim: int, deltas: list[float],
                                        device: torch.device) -> None:
    inputs = _term_inputs(dim, deltas, device)
    x, v = _SubmovementTerms.apply(*inputs)
    plain = _terms(*inputs)
    assert torch.equal(x, plain.x) and torch.equal(v, plain.v)  # the same forward
    g = torch.Generator().manual_seed(7)
    gx, gv = (torch.randn(x.shape, generator=g, dtype=F64).to(device) for _ in range(2))
    ours = torch.autograd.grad((x * gx).sum() + (v * gv).sum(), inputs)
    theirs = torch.autograd.grad((plain.x * gx).sum() + (plain.v * gv).sum(), inputs)
    assert _relative(ours, theirs) < 1e-7
    assert torch.autograd.gradcheck(_SubmovementTerms.apply, tuple(inputs))


def test_the_submovement_terms_slope_in_delta_is_accurate_near_zero_in_float32() -> None:
    """sinc's slope by its series near 0, where (cos πy − sinc y)/y cancels: in float32 the
    gradient in δ is as close to float64's as the other inputs' are."""
    inputs = _term_inputs(2, [1e-4, -3e-4, 1e-3, 3e-3], torch.device("cpu"))
    exact = torch.autograd.grad(sum(o.sum() for o in _SubmovementTerms.apply(*inputs)),
                                inputs)[2]
    single = [t.detach().float().requires_grad_(True) for t in inputs]
    ours = torch.autograd.grad(sum(o.sum() for o in _SubmovementTerms.apply(*single)),
                               single)[2]
    assert float((ours.double() - exact).abs().max() / exact.abs().max()) < 1e-4


def test_without_a_gradient_or_with_accelerations_the_plain_ops_run() -> None:
    inputs = _term_inputs(2, [0.3, -0.4], torch.device("cpu"))
    x, v, a = submovement_terms(*inputs)  # accelerations: autograd's graph
    assert a is not None and x.grad_fn is not None
    assert type(x.grad_fn).__name__ != "_SubmovementTermsBackward"
    with torch.no_grad():
        x0, v0, a0 = submovement_terms(*inputs, accelerations=False)
    assert a0 is None and torch.equal(x0, x) and torch.equal(v0, v)


def _batch(moves: list[int], same_shapes: bool, device: torch.device) -> PlanBatch:
    g = torch.Generator().manual_seed(sum(moves) + same_shapes)
    plans = [MotorPlan(points=torch.rand(m + 1, 2, generator=g, dtype=F64) * 200,
                       delta_t=0.1 + 0.8 * torch.rand(m, generator=g, dtype=F64),
                       delta=torch.zeros(m, dtype=F64),
                       ac=(torch.full((m,), 0.05, dtype=F64) if same_shapes
                           else 1e-4 + 0.1 * torch.rand(m, generator=g, dtype=F64)),
                       T=0.2 + torch.rand(m, generator=g, dtype=F64)) for m in moves]
    batch = PlanBatch.from_plans(plans)
    return PlanBatch(batch.points.to(device), batch.delta_t.to(device).requires_grad_(True),
                     batch.delta.to(device), batch.ac.to(device).requires_grad_(True),
                     batch.T.to(device), batch.moves.to(device), batch.widths.to(device))


@pytest.mark.parametrize("moves", [[4], [3, 1, 5, 2]])
@pytest.mark.parametrize("same_shapes", [True, False])
def test_the_grid_timing_gradient(moves: list[int], same_shapes: bool,
                                  device: torch.device) -> None:
    batch = _batch(moves, same_shapes, device)
    layout = batch.layout()
    (sigma, mu, t0), times, dt = grid_timing(batch, layout)
    timing = batch.timing(layout)
    plain = (*timing, *uniform_times(batch, layout, timing))
    ours_out = (sigma, mu, t0, times, dt)
    assert all(torch.equal(a, b) for a, b in zip(ours_out, plain, strict=True))
    g = torch.Generator().manual_seed(3)
    weights = [torch.randn(t.shape, generator=g, dtype=F64).to(device) for t in plain]
    leaves = (batch.delta_t, batch.ac)
    ours = torch.autograd.grad(
        sum((a * w).sum() for a, w in zip(ours_out, weights, strict=True)), leaves)
    theirs = torch.autograd.grad(
        sum((a * w).sum() for a, w in zip(plain, weights, strict=True)), leaves)
    assert _relative(ours, theirs) < 1e-9
    assert torch.autograd.gradcheck(
        lambda d, a: _GridTiming.apply(d, a, batch.T, layout), leaves)


@pytest.mark.parametrize("same_shapes", [True, False])
def test_the_floor_barrier_gradient(same_shapes: bool, device: torch.device) -> None:
    batch = _batch([5, 4], same_shapes, device)
    with torch.no_grad():  # overlaps near their floor, where the barrier acts
        batch.delta_t.copy_(0.1 + 0.1 * torch.rand(9, generator=torch.Generator()
                                                    .manual_seed(1), dtype=F64))
    used = (~batch.layout().first).to(F64)
    ours_out = _FloorBarrier.apply(batch.delta_t, batch.ac, batch.T, used)
    plain = floor_barrier(_gap_parts(batch.delta_t, batch.ac, batch.T)[-1], used)
    assert torch.equal(ours_out, plain) and bool((plain > 0).any())
    weights = torch.arange(1.0, 10.0, dtype=F64, device=device)
    leaves = (batch.delta_t, batch.ac)
    ours = torch.autograd.grad((ours_out * weights).sum(), leaves)
    theirs = torch.autograd.grad((plain * weights).sum(), leaves)
    assert _relative(ours, theirs) < 1e-9
    assert torch.autograd.gradcheck(
        lambda d, a: _FloorBarrier.apply(d, a, batch.T, used), leaves)


def test_a_graph_through_t_takes_autograds_ops() -> None:
    """T never learns in a fit; a caller that differentiates through it gets the plain
    ops' graph, whose gradient reaches T."""
    batch = _batch([3], False, torch.device("cpu"))
    batch.T.requires_grad_(True)
    (_, _, t0), times, _ = grid_timing(batch, batch.layout())
    (grad,) = torch.autograd.grad(times.sum() + t0.sum(), (batch.T,))
    assert bool(torch.isfinite(grad).all()) and float(grad.abs().sum()) > 0
    assert not math.isnan(float(grad.sum()))
