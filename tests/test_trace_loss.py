"""The trace term (:mod:`inkmotion.fitting.trace_loss`) and the edit decisions that use the
fit's quality criterion (:mod:`inkmotion.fitting.quality`, :mod:`inkmotion.fitting.stages`)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from inkmotion.fitting.optimise import FitResult
from inkmotion.fitting.quality import criterion, poor_above, worst_miss
from inkmotion.fitting.refine import input_turn, salient_targets
from inkmotion.fitting.stages import _Edits, _judge
from inkmotion.fitting.trace_loss import TraceLoss, TraceReference, simplify
from inkmotion.geometry.bezier import batch_bezier_segments
from inkmotion.outputs.sampling import sample
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.plan import MotorPlan

#: a "P": a long stem, then a closed bowl with sharp corners (the shape of a corpus tag
#: whose fit used to take another route)
P_SHAPE = np.array([[29, 149], [29, 46], [109, 46], [109, 95], [68, 104], [28, 93]], float)
#: a straight stroke crossing the P's stem
CROSS = np.array([[10, 120], [60, 120]], float)


def _plan(points: np.ndarray, dtype: torch.dtype = torch.float64) -> MotorPlan:
    return MotorPlan.from_points(points, width=3.0, dtype=dtype)


def _loss(strokes: list[np.ndarray], plans: list[MotorPlan],
          owners_from: list[MotorPlan] | None = None) -> tuple[TraceLoss, PlanBatch]:
    ref = TraceReference.of(strokes, dtype=torch.float64, device="cpu")
    owners = ref.ownership([sample(p).positions for p in owners_from or plans])
    return TraceLoss(ref, owners), PlanBatch.from_plans(plans)


def _value(loss: TraceLoss, batch: PlanBatch, step: int | None = None) -> torch.Tensor:
    layout = batch.layout()
    return loss(batch_bezier_segments(batch, layout), layout, step)


def test_simplify_keeps_the_shape_within_its_tolerance() -> None:
    t = np.linspace(0, np.pi, 400)
    arc = np.column_stack([100 * np.cos(t), 100 * np.sin(t)])
    kept = simplify(arc, 0.25)
    assert 10 < len(kept) < 100
    dense = np.vstack([np.linspace(a, b, 20) for a, b in zip(kept[:-1], kept[1:], strict=True)])
    r = np.hypot(dense[:, 0], dense[:, 1])
    assert r.min() > 100 - 0.3


def test_the_term_is_small_on_the_trace_and_grows_with_a_detour() -> None:
    """A plan through the P's corners with no overlap draws the P: the term is near 0; the
    same plan with a target moved 30 px off is far from it, and its gradient moves that
    target back towards the trace."""
    on = _plan(P_SHAPE)
    loss, batch = _loss([P_SHAPE], [on])
    assert float(_value(loss, batch)) < 0.05
    off_points = P_SHAPE.copy()
    off_points[3] += (30.0, 20.0)
    off = _plan(off_points)
    loss, batch = _loss([P_SHAPE], [off], owners_from=[on])
    pts = batch.points.clone().requires_grad_(True)
    moved = PlanBatch(pts, batch.delta_t, batch.delta, batch.ac, batch.T, batch.moves,
                      batch.widths)
    value = _value(loss, moved)
    assert float(value.detach()) > 1.0
    value.backward()
    step = -pts.grad[3].numpy()
    assert float(step @ (P_SHAPE[3] - off_points[3])) > 0  # downhill is back to the trace


#: a stroke with a spike: up to a point 30 px above the line and straight back down
SPIKE = np.array([[20, 100], [100, 100], [104, 70], [108, 100], [200, 100]], float)


def _spike_cut(worst: float) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The trace term (worst-miss weight ``worst``) of a plan that runs along the line and
    cuts the spike off (its tip 30 px away), and its gradient w.r.t. the plan's targets."""
    line = _plan(np.array([[20, 100], [104, 98], [200, 100]], float))
    ref = TraceReference.of([SPIKE], dtype=torch.float64, device="cpu")
    loss = TraceLoss(ref, ref.ownership([sample(line).positions]), worst=worst)
    batch = PlanBatch.from_plans([line])
    pts = batch.points.clone().requires_grad_(True)
    value = _value(loss, PlanBatch(pts, batch.delta_t, batch.delta, batch.ac, batch.T,
                                   batch.moves, batch.widths))
    value.backward()
    return value.detach(), pts.grad, pts.detach()


def test_the_worst_misses_pull_a_cut_spike_out_to_its_tip() -> None:
    """A spike's tip is a few recall points among many: in the mean they lose to the
    rest of the line, and the middle target is pulled down onto it, away from the tip;
    weighed as the worst misses (a soft maximum beyond 3 px), they pull it up towards the
    tip, and the term grows by about the size of the miss."""
    plain, plain_grad, _ = _spike_cut(0.0)
    worst, worst_grad, _ = _spike_cut(1.0)
    up = np.array([0.0, -1.0])  # towards the tip (y down)
    assert float(-plain_grad[1].numpy() @ up) < 0
    assert float(-worst_grad[1].numpy() @ up) > 0.5
    assert 10.0 < float(worst - plain) < 30.0  # ~ the tip's distance less 3 px


def test_the_worst_misses_cost_nothing_within_a_pen_width() -> None:
    """A plan within 3 px of every input point: the worst-miss part adds nothing."""
    near = _plan(P_SHAPE + np.array([1.5, -1.0]))
    ref = TraceReference.of([P_SHAPE], dtype=torch.float64, device="cpu")
    owners = ref.ownership([sample(near).positions])
    batch = PlanBatch.from_plans([near])
    plain = _value(TraceLoss(ref, owners), batch)
    worst = _value(TraceLoss(ref, owners, worst=1.0), batch)
    assert float(worst) == pytest.approx(float(plain), abs=1e-9)


def test_a_union_weighs_each_drawings_worst_misses_as_its_own_term_does() -> None:
    """Two drawings fitted together: the union's value for each is its own term's, the
    soft maximum taken over its own points only."""
    cut = _plan(np.array([[20, 100], [104, 98], [200, 100]], float))
    near = _plan(P_SHAPE + np.array([1.5, -1.0]))
    own = []
    for stroke, plan in ((SPIKE, cut), (P_SHAPE, near)):
        ref = TraceReference.of([stroke], dtype=torch.float64, device="cpu")
        own.append(TraceLoss(ref, ref.ownership([sample(plan).positions]), worst=1.0))
    union = TraceLoss.union(own, [1, 1])
    values = _value(union, PlanBatch.from_plans([cut, near]))
    for b, (loss, plan) in enumerate(zip(own, (cut, near), strict=True)):
        alone = _value(loss, PlanBatch.from_plans([plan]))
        assert float(values[b]) == pytest.approx(float(alone), rel=1e-9, abs=1e-9)


def test_a_stroke_is_matched_only_to_the_paths_that_follow_it() -> None:
    """The crossing stroke's path does not count as covering the P (and vice versa): a P
    path that skips its bowl pays for it even where the crossing stroke passes nearby."""
    p_path, cross_path = _plan(P_SHAPE), _plan(CROSS)
    ref = TraceReference.of([P_SHAPE, CROSS], dtype=torch.float64, device="cpu")
    owners = ref.ownership([sample(p).positions for p in (p_path, cross_path)])
    assert owners.tolist() == [[True, False], [False, True]]
    anyone = TraceReference.of([P_SHAPE], dtype=torch.float64, device="cpu").ownership(
        [sample(_plan(np.array([[300.0, 300.0], [320.0, 300.0]]))).positions])
    assert anyone.tolist() == [[True]]  # a path that follows nothing may cover anything


def test_ownership_is_each_paths_own_nearest_distance_test_done_once_for_all_paths() -> None:
    """One tree over every path's samples asked once per stroke gives, bit for bit, the
    ownership a tree per path asked per stroke gave (paths × strokes queries: minutes for
    a drawing of thousands of short strokes); random strokes and paths, some crossing."""
    from scipy.spatial import cKDTree

    from inkmotion.fitting.trace_loss import OWN_WITHIN
    from inkmotion.geometry.chamfer import densify

    rng = np.random.default_rng(7)
    strokes = [np.cumsum(rng.normal(0, 6, (rng.integers(2, 9), 2)), 0) + rng.uniform(0, 200, 2)
               for _ in range(40)]
    paths = [s + rng.normal(0, 2.0, s.shape) for s in strokes[:25]] + [
        np.cumsum(rng.normal(0, 20, (6, 2)), 0) + 100 for _ in range(5)]
    ref = TraceReference.of(strokes, dtype=torch.float64, device="cpu")
    own = ref.ownership(paths).numpy()
    reach = OWN_WITHIN * ref.unit
    expected = np.zeros_like(own)
    for p, xy in enumerate(paths):
        tree = cKDTree(densify(xy, 0.5))
        for s, stroke in enumerate(ref.strokes):
            d, _ = tree.query(densify(stroke, 1.0))
            expected[s, p] = np.mean(d <= reach) >= 0.5
    expected[~expected.any(axis=1), :] = True
    expected[:, ~expected.any(axis=0)] = True
    assert 0 < own.sum() < own.size and (own == expected).all()


def test_matches_are_state_and_a_resumed_loss_repeats_the_arithmetic() -> None:
    """Steps between searches reuse the matches; with the matches restored, a second loss
    object gives the same values bit for bit."""
    plan = _plan(P_SHAPE + np.array([0.7, -0.4]))
    loss, batch = _loss([P_SHAPE], [plan])
    values = [float(_value(loss, batch, step)) for step in range(1, 5)]
    saved = loss.state()
    again, _ = _loss([P_SHAPE], [plan])
    _value(again, batch)  # the layout's first call (no step: keeps no state)
    again.load_state(saved)
    assert float(_value(again, batch, 5)) == float(_value(loss, batch, 5))
    assert len(set(values)) == 1


def test_the_criterion_and_the_poor_threshold_scale_with_the_canvas() -> None:
    assert criterion(0.6, 8.0, 350) == pytest.approx(2.0)
    assert criterion(1.2, 16.0, 700) == pytest.approx(2.0)
    assert poor_above(700) == pytest.approx(16.0)


def test_worst_miss_names_the_stroke_a_fit_leaves_out() -> None:
    plans = [_plan(P_SHAPE[:3])]  # the stem and top only: the bowl is missing
    miss = worst_miss([CROSS, P_SHAPE], plans)
    assert miss.stroke in (0, 1) and miss.distance > 30


def test_sharp_corners_are_salient_and_smooth_bends_are_not() -> None:
    t = np.linspace(0, np.pi / 2, 200)
    arc = np.column_stack([200 * np.cos(t), 200 * np.sin(t)])
    assert input_turn([arc], arc[100], 8.0) < 10
    assert input_turn([P_SHAPE], P_SHAPE[2], 8.0) == pytest.approx(90, abs=1)
    plan = _plan(P_SHAPE)
    assert salient_targets(plan, [P_SHAPE], 350.0) == {1, 2, 3}  # (68, 104) turns by 28°


def _result(mean: float) -> FitResult:
    return FitResult([], {}, {"total": mean}, [], [], torch.zeros(1, 1), 0.0, 1)


def test_an_edit_whose_refit_is_worse_is_rolled_back_and_says_why() -> None:
    edits = _Edits()
    first = _result(1.0)
    kept, rolled = _judge(edits, first, (0.5, 4.0), 350.0, {})
    assert kept is first and not rolled  # no edit yet: kept as it is
    edits.pending = {"inserted": 0, "merged": 2}
    entry: dict = {}
    kept, rolled = _judge(edits, _result(2.0), (0.5, 9.0), 350.0, entry)
    assert rolled and kept is first
    assert entry["edit"]["kept"] is False and "rolled back" in entry["edit"]["why"]
    assert not edits.merges_allowed and not edits.frozen  # next time: insertions only
    edits.pending = {"inserted": 1, "merged": 0}
    better = _result(0.5)
    kept, rolled = _judge(edits, better, (0.4, 3.0), 350.0, {})
    assert kept is better and not rolled and edits.quality == (0.4, 3.0)
