"""The minimum-time cost L_smooth (fitting.losses.smoothing_cost): T_end divided by the
plan's own sub-movement counts, or by fixed ones (a fit's initial plan, spec 12), so a
plan edit's new targets do not make the motion's time cheaper; the overlaps' floor
barrier (spec 15), which keeps Δt off its clamp floor from inside."""

from __future__ import annotations

import pytest
import torch

from inkmotion.fitting.losses import (
    FLOOR_BAND,
    FLOOR_EPSILON,
    floor_barrier,
    overlap_gaps,
    smoothing_cost,
    smoothing_costs,
)
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.plan import MotorPlan


def _batch(moves: list[int]) -> PlanBatch:
    g = torch.Generator().manual_seed(sum(moves))
    plans = [MotorPlan(points=torch.rand(m + 1, 2, generator=g, dtype=torch.float64) * 200,
                       delta_t=0.1 + 0.8 * torch.rand(m, generator=g, dtype=torch.float64),
                       delta=torch.zeros(m, dtype=torch.float64),
                       ac=torch.full((m,), 0.05, dtype=torch.float64),
                       T=torch.full((m,), 0.3, dtype=torch.float64)) for m in moves]
    return PlanBatch.from_plans(plans)


@pytest.mark.parametrize("over", ["pooled", "drawing", "path"])
def test_the_plans_own_counts_give_the_same_bits_as_none(over):
    batch = _batch([3, 1, 5])
    layout = batch.layout()
    t_end = torch.tensor([1.5, 0.7, 2.25], dtype=torch.float64)
    own = smoothing_cost(batch, t_end, 10.0, layout, over)
    same = smoothing_cost(batch, t_end, 10.0, layout, over, layout.moves.clone())
    assert torch.equal(own, same)


@pytest.mark.parametrize("over, expected", [
    # the time part alone (w_σ = 0): Σ T_end / Σ m0, or the mean over paths of T_end / m0
    ("pooled", (1.5 + 0.7 + 2.25) / (2 + 1 + 4)),
    ("drawing", (1.5 + 0.7 + 2.25) / (2 + 1 + 4)),
    ("path", (1.5 / 2 + 0.7 / 1 + 2.25 / 4) / 3),
])
def test_fixed_counts_divide_t_end_and_not_the_plans_own(over, expected):
    batch = _batch([3, 1, 5])  # an edit added a target to paths 0 and 2
    layout = batch.layout()
    t_end = torch.tensor([1.5, 0.7, 2.25], dtype=torch.float64)
    cost = smoothing_cost(batch, t_end, 0.0, layout, over, torch.tensor([2, 1, 4]))
    assert float(cost) == pytest.approx(expected, rel=1e-12)
    cheaper = smoothing_cost(batch, t_end, 0.0, layout, over)  # the plan's own 3, 1, 5
    assert float(cheaper) < float(cost)


def test_the_variance_part_does_not_depend_on_the_counts():
    batch = _batch([3, 2])
    layout = batch.layout()
    zero = torch.zeros(2, dtype=torch.float64)
    a = smoothing_cost(batch, zero, 10.0, layout, "pooled")
    b = smoothing_cost(batch, zero, 10.0, layout, "pooled", torch.tensor([1, 1]))
    assert torch.equal(a, b) and float(a) > 0


def test_an_objective_refuses_counts_for_other_paths():
    from inkmotion.fitting.objective import Objective, Weights

    weights = Weights(lambda_smooth=45.0, w_image=0.0, w_sigma=10.0, w_canvas=1.0,
                      samples_per_move=5, smooth_over="pooled", w_trace=0.0, w_floor=0.0)
    objective = Objective(renderer=None, image_losses={}, canvas=(100, 100),  # type: ignore
                          weights=weights, time_moves=[2, 2, 2])
    with pytest.raises(ValueError, match="3 paths, the plans 2"):
        objective._time_moves_on(_batch([3, 2]))


@pytest.mark.parametrize("version, fixed", [(12, True), (11, False)])
def test_a_fit_divides_time_by_its_initial_plans_counts_from_spec_12(tmp_path, version, fixed):
    import torch as _torch

    from inkmotion.jobs.kind import resolve
    from inkmotion.jobs.shell import Job, ObserverGroup
    from inkmotion.jobs.spec import JobSpec
    from inkmotion.kinds.fit import _prepare

    spec = JobSpec.from_dict({"version": version, "kind": "fit",
                              "inputs": {"drawing": "text:hi"}, "params": {"steps": 5}})
    resolved = resolve(spec)
    job = Job(spec, resolved.params, _torch.device("cpu"), tmp_path, ObserverGroup([]),
              resolved, 5)
    problem, _ = _prepare(job)
    expected = tuple(plan.m for plan in problem.plans) if fixed else None
    assert problem.objective.time_moves == expected


def test_the_floor_barrier_acts_only_near_the_floor_and_pushes_off_it():
    floor = 0.1
    gaps = torch.tensor([0.0, 0.005, 0.02, FLOOR_BAND - FLOOR_EPSILON - 1e-9, 0.06, 0.8],
                        dtype=torch.float64)
    delta_t = (floor + gaps).requires_grad_(True)
    b = floor_barrier(delta_t, torch.ones_like(delta_t))
    b.sum().backward()
    b, grad = b.detach(), delta_t.grad
    assert torch.isfinite(b).all() and torch.isfinite(grad).all()
    assert (b[:3] > 0).all() and b[4:].eq(0).all() and grad[4:].eq(0).all()
    assert float(b[3]) == pytest.approx(0.0, abs=1e-12)  # B and B′ vanish at the band's edge
    assert float(grad[3]) == pytest.approx(0.0, abs=1e-6)
    assert (grad[:3] < 0).all() and grad[0] < grad[1] < grad[2]  # the harder the nearer
    unused = floor_barrier(delta_t.detach(), torch.zeros_like(delta_t))
    assert unused.eq(0).all()  # each path's Δt_1 sets no onset


@pytest.mark.parametrize("over", ["pooled", "drawing", "path"])
def test_the_barrier_settles_an_overlap_where_it_meets_the_time_costs_pull(over):
    """Time cost alone (w_σ = 0) against the barrier: Δt_2 of a two-move path stops where
    T_2·g² + w·g − w·band = 0 (g = Δt − floor + ε), the same for every form of the cost."""
    w, T = 0.0064, 0.3
    g = (-w + (w * w + 4 * T * w * FLOOR_BAND) ** 0.5) / (2 * T)
    plan = MotorPlan(points=torch.tensor([[0.0, 0.0], [50.0, 0.0], [50.0, 40.0]],
                                         dtype=torch.float64),
                     delta_t=torch.tensor([0.9, 0.1 + g - FLOOR_EPSILON], dtype=torch.float64),
                     delta=torch.zeros(2, dtype=torch.float64),
                     ac=torch.full((2,), 0.05, dtype=torch.float64),
                     T=torch.full((2,), T, dtype=torch.float64))
    batch = PlanBatch.from_plans([plan])
    batch.delta_t.requires_grad_(True)
    layout = batch.layout()
    cost = smoothing_cost(batch, batch.end_times(layout), 0.0, layout, over, w_floor=w)
    cost.backward()
    assert float(batch.delta_t.grad[1]) == pytest.approx(0.0, abs=1e-9)
    batch.delta_t.grad = None
    smoothing_cost(batch, batch.end_times(layout), 0.0, layout, over).backward()
    assert float(batch.delta_t.grad[1]) > 0  # without it the time cost pulls it down


@pytest.mark.parametrize("over", ["pooled", "drawing", "path"])
def test_drawings_fitted_together_feel_their_own_barrier(over):
    a, b = _batch([3, 1]), _batch([2, 4])
    for batch in (a, b):
        batch.delta_t.data[1] = 0.1005  # one overlap near its floor in each drawing
    both = PlanBatch.from_plans(a.to_plans() + b.to_plans())
    layout = both.layout()
    t_end = both.end_times(layout)
    together = smoothing_costs(both, t_end, 10.0, layout, over, torch.tensor([0, 0, 1, 1]), 2,
                               w_floor=0.0064)
    alone = [smoothing_cost(x, x.end_times(), 10.0, None, over, w_floor=0.0064)
             for x in (a, b)]
    assert together.tolist() == pytest.approx([float(c) for c in alone], rel=1e-12)
    assert (together > smoothing_costs(both, t_end, 10.0, layout, over,
                                       torch.tensor([0, 0, 1, 1]), 2)).all()


def _pair(ac: tuple[float, float], delta_t: float = 0.3) -> PlanBatch:
    return PlanBatch.from_plans([MotorPlan(
        points=torch.tensor([[0.0, 0.0], [50.0, 0.0], [50.0, 40.0]], dtype=torch.float64),
        delta_t=torch.tensor([0.9, delta_t], dtype=torch.float64),
        delta=torch.zeros(2, dtype=torch.float64),
        ac=torch.tensor(ac, dtype=torch.float64),
        T=torch.full((2,), 0.8, dtype=torch.float64))])


def _peaks(batch: PlanBatch) -> torch.Tensor:
    """The two lognormals' modes t0 + e^{μ−σ²}, from the onsets the kinematics use."""
    sigma, mu, t0 = batch.timing()
    return t0 + torch.exp(mu - sigma * sigma)


def test_an_overlaps_gap_is_its_window_gap_where_the_shapes_agree():
    batch = _pair((0.05, 0.05))
    assert float(overlap_gaps(batch)[1]) == 0.3  # exactly Δt: the leads cancel


@pytest.mark.parametrize("ac, nearer", [((1e-4, 0.1), "peaks"), ((0.1, 1e-4), "windows")])
def test_an_overlaps_gap_is_the_nearer_of_its_windows_and_its_peaks(ac, nearer):
    """A skewed sub-movement after a symmetric one peaks early in a window that opens
    later: its peak comes sooner than Δt says; the other way round the peaks are further
    apart than the windows, and Δt is the gap."""
    batch = _pair(ac)
    peaks = _peaks(batch)
    peak_gap = float((peaks[1] - peaks[0]) / 0.8)
    gap = float(overlap_gaps(batch)[1])
    if nearer == "peaks":
        assert peak_gap < 0.3 and gap == pytest.approx(peak_gap, abs=1e-12)
    else:
        assert peak_gap > 0.3 and gap == 0.3


def test_the_barrier_pushes_peaks_that_crossed_the_floor_apart():
    batch = _pair((1e-4, 0.1), delta_t=0.12)  # the second peaks before the first
    assert float(overlap_gaps(batch)[1]) < 0.1
    batch.ac.requires_grad_(True)
    used = (~batch.layout().first).to(batch.ac.dtype)
    b = floor_barrier(overlap_gaps(batch), used)
    b.sum().backward()
    b = b.detach()
    assert torch.isfinite(b).all() and float(b[1]) > 0
    # descent: less skew after (its peak later), more before (its peak sooner)
    assert float(batch.ac.grad[0]) < 0 < float(batch.ac.grad[1])
