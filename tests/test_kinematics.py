"""ΣΛ kinematics: derivatives by finite differences, end points, windowing, batching."""

from __future__ import annotations

import math

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

import inkmotion.sigma_lognormal.kinematics as kin_module
from inkmotion import MotorPlan, kinematics
from inkmotion.sigma_lognormal import PlanBatch, batch_kinematics
from inkmotion.sigma_lognormal.params import sigma_mu

F64 = torch.float64


def make_plan(m: int, dim: int, delta: float | None, seed: int) -> MotorPlan:
    g = torch.Generator().manual_seed(seed)
    pts = torch.cumsum(torch.randn(m + 1, dim, generator=g, dtype=F64) * 30.0, 0)
    if dim == 3:
        pts[:, 2] = 1.0 + torch.rand(m + 1, generator=g, dtype=F64) * 4.0
    plan = MotorPlan.from_points(pts, dtype=F64)
    plan.delta_t.uniform_(0.1, 1.0, generator=g)
    plan.ac.uniform_(0.005, 0.1, generator=g)
    if delta is None:
        plan.delta.uniform_(-math.pi / 2, math.pi / 2, generator=g)
    else:
        plan.delta.fill_(delta)
    return plan


DELTAS = [0.0, 1e-9, 1e-4, -1e-4, math.pi / 2, -math.pi / 2, None]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("delta", DELTAS)
def test_finite_differences(dim: int, delta: float | None) -> None:
    plan = make_plan(8, dim, delta, seed=3)
    t_end = float(plan.end_time)
    t = torch.rand(300, generator=torch.Generator().manual_seed(1), dtype=F64) * t_end
    h = 1e-6
    x_p, v_p, _ = kinematics(plan, t + h)
    x_m, v_m, _ = kinematics(plan, t - h)
    _, v, a = kinematics(plan, t)
    v_scale = v.abs().max()
    a_scale = a.abs().max()
    torch.testing.assert_close((x_p - x_m) / (2 * h), v, atol=1e-5 * v_scale, rtol=0)
    torch.testing.assert_close((v_p - v_m) / (2 * h), a, atol=1e-5 * a_scale, rtol=0)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("delta", DELTAS)
def test_end_points(dim: int, delta: float | None) -> None:
    """With a common Ac (as fitted), every ±3σ window lies in [0, T_end]."""
    plan = make_plan(6, dim, delta, seed=7)
    plan.ac.fill_(0.01)
    x = kinematics(plan, torch.tensor([0.0, float(plan.end_time)], dtype=F64)).positions
    length = (plan.points[1:, :2] - plan.points[:-1, :2]).norm(dim=1).sum()
    assert (x[0, :2] - plan.points[0, :2]).norm() <= 0.005 * length
    assert (x[1, :2] - plan.points[-1, :2]).norm() <= 0.005 * length


def paper_position(plan: MotorPlan, t: torch.Tensor) -> torch.Tensor:
    """Dense reference: the paper's closed form with M and Z, every sub-movement everywhere."""
    sigma, mu = sigma_mu(plan.ac, plan.T)
    t0 = torch.empty_like(sigma)
    t0[0] = -torch.exp(mu[0] - 3 * sigma[0])
    for i in range(1, plan.m):
        t0[i] = t0[i - 1] + plan.delta_t[i] * plan.T[i]
    x = plan.points[0].expand(len(t), -1).clone()
    for i in range(plan.m):
        d = plan.points[i + 1] - plan.points[i]
        tau = torch.clamp(t - t0[i], min=1e-12)
        w = 0.5 * (1 + torch.erf((torch.log(tau) - mu[i]) / (sigma[i] * math.sqrt(2))))
        dl = plan.delta[i]
        if abs(float(dl)) > 1e-6:
            m_mat = torch.tensor([[0.0, -1.0], [1.0, 0.0]], dtype=F64) / (2 * torch.tan(dl / 2))
            for k in range(len(t)):
                a = dl * w[k] - dl
                rot = torch.stack((torch.stack((torch.cos(a), -torch.sin(a))),
                                   torch.stack((torch.sin(a), torch.cos(a)))))
                planar = (0.5 * d[:2] + rot @ (d[:2] / 2 - m_mat @ d[:2]) + m_mat @ d[:2])
                x[k, :2] += planar
        else:
            x[:, :2] += w[:, None] * d[:2]
        if plan.dim == 3:
            x[:, 2] += w * d[2]
    return x


@pytest.mark.parametrize("delta", [0.0, 0.7, -1.3, None])
def test_position_matches_paper_closed_form(delta: float | None) -> None:
    plan = make_plan(4, 3, delta, seed=11)
    t = torch.linspace(0, float(plan.end_time), 40, dtype=F64)
    torch.testing.assert_close(kinematics(plan, t).positions, paper_position(plan, t),
                               atol=1e-6 * plan.points.abs().max(), rtol=0)


def test_window_equals_dense(monkeypatch: pytest.MonkeyPatch) -> None:
    plan = make_plan(30, 2, None, seed=5)
    t = torch.linspace(0, float(plan.end_time), 500, dtype=F64)
    windowed = kinematics(plan, t)
    monkeypatch.setattr(kin_module, "SUPPORT_SIGMAS", 60.0)  # every sample in every window
    dense = kinematics(plan, t)
    # truncating at ±5σ neglects Φ(−5) ≈ 3e-7 of each displacement, and a little more of
    # the faster-decaying derivatives
    for got, ref, tol in zip(windowed, dense, (1e-6, 1e-4, 1e-3), strict=True):
        torch.testing.assert_close(got, ref, atol=tol * float(ref.abs().max()), rtol=0)


def test_batch_equals_single_paths() -> None:
    plans = [make_plan(m, 2, None, seed=m) for m in (1, 5, 12)]
    times = [torch.linspace(0, float(p.end_time), 37, dtype=F64) for p in plans]
    out = batch_kinematics(PlanBatch.from_plans(plans), torch.cat(times),
                           torch.tensor([37, 37, 37]))
    parts = torch.split(out.positions, 37)
    for p, t, part in zip(plans, times, parts, strict=True):
        torch.testing.assert_close(part, kinematics(p, t).positions)


def test_unsorted_times_are_accepted() -> None:
    plan = make_plan(5, 2, None, seed=2)
    t = torch.linspace(0, float(plan.end_time), 50, dtype=F64)
    perm = torch.randperm(50, generator=torch.Generator().manual_seed(0))
    expected = kinematics(plan, t).positions[perm]
    torch.testing.assert_close(kinematics(plan, t[perm]).positions, expected)


@pytest.mark.parametrize("delta", [0.0, 1e-12, math.pi / 2])
def test_gradients_finite(delta: float) -> None:
    plan = make_plan(6, 3, delta, seed=4)
    for name in ("points", "delta_t", "delta", "ac"):
        getattr(plan, name).requires_grad_(True)
    t = torch.linspace(0, float(plan.end_time.detach()), 100, dtype=F64)
    x, v, a = kinematics(plan, t)
    (x.sum() + v.sum() + a.sum() + plan.end_time).backward()
    for name in ("points", "delta_t", "delta", "ac"):
        grad = getattr(plan, name).grad
        assert grad is not None and torch.isfinite(grad).all(), name


@settings(max_examples=25, deadline=None)
@given(m=st.integers(1, 12), seed=st.integers(0, 10_000),
       dt=st.floats(0.1, 1.0), delta=st.floats(-math.pi / 2, math.pi / 2))
def test_property_reaches_last_target(m: int, seed: int, dt: float, delta: float) -> None:
    plan = make_plan(m, 2, delta, seed)
    plan.delta_t.fill_(dt)
    x = kinematics(plan, torch.tensor([float(plan.end_time) + 10.0], dtype=F64)).positions
    torch.testing.assert_close(x[0], plan.points[-1], atol=1e-4 * plan.points.abs().max(), rtol=0)


def test_end_time_matches_onsets() -> None:
    plan = MotorPlan.from_points([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]], dtype=F64)
    sigma, mu = sigma_mu(plan.ac, plan.T)
    # first window starts at 0 and lasts T; the second starts Δt·T later
    expected = float(plan.delta_t[1] * plan.T[1] + plan.T[1])
    assert float(plan.end_time) == pytest.approx(expected, rel=1e-9)
    assert float(torch.exp(mu + 3 * sigma)[0] - torch.exp(mu - 3 * sigma)[0]) == pytest.approx(0.8)
