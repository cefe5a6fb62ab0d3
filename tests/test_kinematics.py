"""ΣΛ kinematics: derivatives by finite differences, end points, windowing, batching."""

from __future__ import annotations

import math

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

import inkmotion.sigma_lognormal.kinematics as kin_module
from inkmotion import MotorPlan, kinematics
from inkmotion.sigma_lognormal import (
    GridLayout,
    PlanBatch,
    batch_kinematics,
    evaluate_kinematics,
)
from inkmotion.sigma_lognormal.kinematics import plan_window, uniform_times
from inkmotion.sigma_lognormal.params import sigma_mu

F64 = torch.float64


def on(plan: MotorPlan, device: torch.device) -> MotorPlan:
    """The plan with its tensors on ``device``."""
    return MotorPlan(*(getattr(plan, k).to(device) for k in ("points", "delta_t", "delta", "ac",
                                                              "T")), plan.width)


def make_plan(m: int, dim: int, delta: float | None, seed: int,
              device: torch.device | str = "cpu") -> MotorPlan:
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
    return on(plan, torch.device(device))


DELTAS = [0.0, 1e-9, 1e-4, -1e-4, math.pi / 2, -math.pi / 2, None]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("delta", DELTAS)
def test_finite_differences(dim: int, delta: float | None, device: torch.device) -> None:
    plan = make_plan(8, dim, delta, seed=3, device=device)
    t_end = float(plan.end_time)
    t = torch.rand(300, generator=torch.Generator().manual_seed(1), dtype=F64).to(device) * t_end
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
def test_end_points(dim: int, delta: float | None, device: torch.device) -> None:
    """With a common Ac (as fitted), every ±3σ window lies in [0, T_end]."""
    plan = make_plan(6, dim, delta, seed=7, device=device)
    plan.ac.fill_(0.01)
    x = kinematics(plan, torch.tensor([0.0, float(plan.end_time)], dtype=F64,
                                      device=device)).positions
    length = (plan.points[1:, :2] - plan.points[:-1, :2]).norm(dim=1).sum()
    assert (x[0, :2] - plan.points[0, :2]).norm() <= 0.005 * length
    assert (x[1, :2] - plan.points[-1, :2]).norm() <= 0.005 * length


def paper_position(plan: MotorPlan, t: torch.Tensor) -> torch.Tensor:
    """Dense reference: the paper's closed form with M and Z, every sub-movement everywhere."""
    sigma, mu = sigma_mu(plan.ac, plan.T)
    t0 = torch.empty_like(sigma)
    t0[0] = -torch.exp(mu[0] - 3 * sigma[0])
    lead = torch.exp(mu - 3 * sigma)  # t0 to the window's opening
    for i in range(1, plan.m):  # window openings Δt_i·T_i apart (the t0 too where Ac are equal)
        t0[i] = t0[i - 1] + plan.delta_t[i] * plan.T[i] + lead[i - 1] - lead[i]
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
def test_position_matches_paper_closed_form(delta: float | None, device: torch.device) -> None:
    plan = make_plan(4, 3, delta, seed=11)
    t = torch.linspace(0, float(plan.end_time), 40, dtype=F64)
    got = kinematics(on(plan, device), t.to(device)).positions.cpu()
    torch.testing.assert_close(got, paper_position(plan, t),
                               atol=1e-6 * plan.points.abs().max(), rtol=0)


def test_window_equals_dense(monkeypatch: pytest.MonkeyPatch, device: torch.device) -> None:
    plan = make_plan(30, 2, None, seed=5, device=device)
    t = torch.linspace(0, float(plan.end_time), 500, dtype=F64, device=device)
    windowed = kinematics(plan, t)
    monkeypatch.setattr(kin_module, "SUPPORT_SIGMAS", 60.0)  # every sample in every window
    dense = kinematics(plan, t)
    # truncating at ±5σ neglects Φ(−5) ≈ 3e-7 of each displacement, and a little more of
    # the faster-decaying derivatives
    for got, ref, tol in zip(windowed, dense, (1e-6, 1e-4, 1e-3), strict=True):
        torch.testing.assert_close(got, ref, atol=tol * float(ref.abs().max()), rtol=0)


def test_batch_equals_single_paths(device: torch.device) -> None:
    plans = [make_plan(m, 2, None, seed=m, device=device) for m in (1, 5, 12)]
    times = [torch.linspace(0, float(p.end_time), 37, dtype=F64, device=device) for p in plans]
    batch = PlanBatch.from_plans(plans)
    layout = batch.layout(torch.full((3,), 37, device=device), n_samples=111)
    out = batch_kinematics(batch, torch.cat(times), layout)
    parts = torch.split(out.positions, 37)
    for p, t, part in zip(plans, times, parts, strict=True):
        torch.testing.assert_close(part, kinematics(p, t).positions)


def test_unsorted_times_are_accepted(device: torch.device) -> None:
    plan = make_plan(5, 2, None, seed=2, device=device)
    t = torch.linspace(0, float(plan.end_time), 50, dtype=F64, device=device)
    perm = torch.randperm(50, generator=torch.Generator().manual_seed(0)).to(device)
    expected = kinematics(plan, t).positions[perm]
    torch.testing.assert_close(kinematics(plan, t[perm]).positions, expected)


def test_long_plans_are_evaluated_in_chunks_to_the_same_bits(
        monkeypatch: pytest.MonkeyPatch, device: torch.device) -> None:
    """A long plan's samples (hours at 1 kHz: a plotter's, a robot's) are taken a chunk at a
    time, each with only the sub-movements whose support it meets (a 100 000-move plan
    asked for 1.4 GB at once): the same values as in one piece (to the last bits: a
    chunk sums the sub-movements done before it in another order)."""
    plan = make_plan(60, 2, None, seed=5, device=device)
    t = torch.linspace(-0.5, float(plan.end_time) + 0.5, 3001, dtype=F64, device=device)
    t = t[torch.randperm(t.numel(), generator=torch.Generator().manual_seed(2)).to(device)]
    whole = kinematics(plan, t)
    monkeypatch.setattr(kin_module, "KINEMATICS_CHUNK", 97)
    for a, b in zip(kinematics(plan, t), whole, strict=True):
        torch.testing.assert_close(a, b, rtol=1e-12, atol=1e-12 * float(b.abs().max()))


@pytest.mark.parametrize("delta", [0.0, 1e-12, math.pi / 2])
def test_gradients_finite(delta: float, device: torch.device) -> None:
    plan = make_plan(6, 3, delta, seed=4, device=device)
    for name in ("points", "delta_t", "delta", "ac"):
        getattr(plan, name).requires_grad_(True)
    t = torch.linspace(0, float(plan.end_time.detach()), 100, dtype=F64, device=device)
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


@pytest.mark.parametrize("ac", [(0.1, 1e-4), (1e-4, 0.1), (0.01, 0.01, 0.05)])
def test_each_window_opens_delta_t_after_the_one_before_whatever_its_shape(
        ac: tuple[float, ...]) -> None:
    """Δt_i·T_i between window openings also where the Ac differ (--lr-ac, a plan edited
    by hand): the window opens e^(μ−3σ) after t0, 13 s at Ac 1e-4 and 0.13 s at 0.1, and
    chaining the t0 alone opened the second window 12.4 s late, or before t = 0 (T_end
    −11.6 s); with equal Ac it is the authors' t0_i = t0_(i−1) + Δt_i·T_i, to the bit."""
    m = len(ac)
    plan = MotorPlan.from_points([[10.0 * i, 5.0 * (i % 2)] for i in range(m + 1)], dtype=F64)
    plan.ac = torch.tensor(ac, dtype=F64)
    plan.delta_t = torch.full((m,), 0.5, dtype=F64)
    batch = PlanBatch.from_plans([plan])
    sigma, mu, t0 = batch.timing()
    opens = t0 + torch.exp(mu - 3 * sigma)
    torch.testing.assert_close(opens, 0.4 * torch.arange(m, dtype=F64), atol=1e-12, rtol=0)
    assert float(plan.end_time) == pytest.approx(0.4 * (m - 1) + 0.8, abs=1e-12)
    equal = MotorPlan.from_points([[0.0, 0.0], [9.0, 1.0], [3.0, 7.0], [5.0, 5.0]])
    equal.delta_t = torch.tensor([1.0, 0.37, 0.61])
    sigma, mu, t0 = PlanBatch.from_plans([equal]).timing()
    steps = equal.delta_t * equal.T
    assert torch.equal(t0, torch.cumsum(torch.cat([-torch.exp(mu - 3 * sigma)[:1], steps[1:]]),
                                         0))


def needed_window(batch: PlanBatch, layout: GridLayout) -> int:
    """The most samples of the fitting grid any sub-movement's support covers."""
    times, _ = uniform_times(batch, layout)
    sigma, mu, t0 = batch.timing(layout)
    lo, hi, _ = kin_module._window_bounds(times, t0, sigma, mu, layout)
    return int((hi - lo).max())


def fitting_batch(device: torch.device, ms: tuple[int, ...] = (3, 17, 40)) -> PlanBatch:
    return PlanBatch.from_plans([make_plan(m, 2, None, seed=m, device=device) for m in ms])


def test_layout_indices(device: torch.device) -> None:
    batch = fitting_batch(device, (2, 3))
    layout = batch.layout()  # counts 11, 16
    assert (layout.n_paths, layout.n_moves, layout.n_samples, layout.n_segments) == (2, 5, 27, 25)
    assert layout.counts.tolist() == [11, 16] and layout.block_start.tolist() == [0, 11]
    assert layout.move_path.tolist() == [0, 0, 1, 1, 1]
    assert layout.first.tolist() == [True, False, True, False, False]
    assert layout.last.tolist() == [False, True, False, False, True]
    assert layout.move_first.tolist() == [0, 0, 2, 2, 2]
    assert layout.move_point.tolist() == [1, 2, 4, 5, 6]
    assert layout.start_point.tolist() == [0, 3]
    assert layout.segment_start.tolist() == list(range(10)) + list(range(11, 26))
    assert layout.sample_step.tolist() == list(range(11)) + list(range(16))


def test_static_window_equals_dynamic(device: torch.device) -> None:
    """A static window wider than every support gives the very same kinematics."""
    batch = fitting_batch(device)
    layout = batch.layout()
    times, _ = uniform_times(batch, layout)
    dynamic, none = evaluate_kinematics(batch, times, layout)
    static_layout = plan_window(batch, times, layout)
    assert none is None and static_layout.window is not None
    static, overflow = evaluate_kinematics(batch, times, static_layout)
    assert not bool(overflow)
    for got, ref in zip(static, dynamic, strict=True):
        if device.type == "cpu":
            assert torch.equal(got, ref)
        else:  # index_add order is not deterministic on CUDA
            torch.testing.assert_close(got, ref)


def test_static_window_too_small_is_flagged_and_degrades_gracefully(device: torch.device) -> None:
    batch = fitting_batch(device)
    layout = batch.layout()
    times, _ = uniform_times(batch, layout)
    ref = batch_kinematics(batch, times, layout)
    need = needed_window(batch, layout)
    small, overflow = evaluate_kinematics(batch, times, layout.with_window(need - 2))
    assert bool(overflow)
    # the window keeps the samples around the median: the tails lost are small
    scale = float(ref.positions.abs().max())
    assert float((small.positions - ref.positions).abs().max()) < 0.05 * scale
    exact, alarm = evaluate_kinematics(batch, times, layout.with_window(need))
    assert bool(alarm)  # nothing truncated yet, but the flag asks for a replan already
    for got, want in zip(exact, ref, strict=True):
        torch.testing.assert_close(got, want)
    _, fits = evaluate_kinematics(batch, times, layout.with_window(need * 4 // 3 + 1))
    assert not bool(fits)


def test_public_api_equals_layout_path(device: torch.device) -> None:
    """kinematics(plan, t) (a layout per call) equals the fitting-grid evaluation."""
    plan = make_plan(9, 3, None, seed=8, device=device)
    batch = PlanBatch.from_plans([plan])
    layout = batch.layout()
    times, _ = uniform_times(batch, layout)
    torch.testing.assert_close(kinematics(plan, times).positions,
                               batch_kinematics(batch, times, layout).positions)


@settings(max_examples=25, deadline=None)
@given(ms=st.lists(st.integers(1, 60), min_size=1, max_size=3), seed=st.integers(0, 10_000),
       dt_low=st.floats(0.1, 0.9), ac_high=st.floats(1e-4, 0.1))
def test_property_clamp_window_covers_every_clamped_plan(ms: list[int], seed: int,
                                                           dt_low: float, ac_high: float) -> None:
    """A window planned with the clamps (Δt ≥ 0.1, Ac ≤ 0.1) on the initial plans covers
    every support of any plan within them, however far the fit takes Δt and Ac."""
    batch = PlanBatch.from_plans([MotorPlan.from_points(
        torch.cumsum(torch.randn(m + 1, 2, generator=torch.Generator().manual_seed(seed + m),
                                 dtype=F64) * 20, 0), dtype=F64) for m in ms])
    layout = batch.layout()
    planned = plan_window(batch, uniform_times(batch, layout)[0], layout, min_delta_t=0.1,
                          max_ac=0.1)
    g = torch.Generator().manual_seed(seed)
    batch.delta_t.uniform_(dt_low, max(dt_low, 0.9), generator=g)
    batch.ac.uniform_(1e-4, ac_high, generator=g)
    assert needed_window(batch, layout) <= planned.window
