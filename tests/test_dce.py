"""DCE initialiser: salient points of simple shapes, monotonicity, radius, registration,
the canvas-free density, a count of targets, and the initial turning angles."""

import math
from pathlib import Path

import numpy as np
import pytest
import torch

import inkmotion
from inkmotion.errors import SpecError
from inkmotion.geometry.traces import Traces
from inkmotion.initialisers.dce import (
    dce,
    dce_indices,
    fitted_turn,
    initial_turns,
    moves_at,
    relevance_threshold,
    threshold_for_moves,
)
from inkmotion.plugin_host.protocols import JobInputs

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "gml"


def _square(noise: float = 0.05, per_side: int = 50, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    corners = np.array([[0, 0], [100, 0], [100, 100], [0, 100], [0, 0]], dtype=float)
    pts = [np.linspace(a, b, per_side, endpoint=False)
           for a, b in zip(corners[:-1], corners[1:], strict=True)]
    p = np.vstack(pts + [corners[-1:]])
    p[1:-1] += rng.normal(scale=noise, size=p[1:-1].shape)
    return p


@pytest.mark.parametrize(("noise", "threshold"), [(0.05, 1.0), (0.2, 3.0)])
def test_noisy_square_reduces_to_corners(noise: float, threshold: float) -> None:
    p = _square(noise)
    out = dce(p, threshold)
    # endpoints (both at the start corner) and the three other corners
    assert len(out) == 5
    np.testing.assert_allclose(out[0], p[0])
    np.testing.assert_allclose(out[-1], p[-1])
    for c in ([100, 0], [100, 100], [0, 100]):
        assert np.min(np.hypot(*(out - c).T)) < 2.0


def test_straight_line_keeps_endpoints_only() -> None:
    p = np.column_stack((np.linspace(0, 50, 200), np.linspace(10, 30, 200)))
    out = dce(p, 1.0)
    np.testing.assert_allclose(out, p[[0, -1]])


def test_threshold_is_monotonic() -> None:
    rng = np.random.default_rng(1)
    p = np.cumsum(rng.normal(size=(2000, 2)), axis=0)
    counts = [len(dce_indices(p, th)) for th in (0.0, 0.1, 0.5, 1.0, 4.0, 20.0, 1e9)]
    assert counts == sorted(counts, reverse=True)
    assert counts[-1] == 2 and counts[0] > counts[-1]
    # a lower threshold keeps a superset of the vertices (DCE is a removal order)
    assert set(dce_indices(p, 4.0)) <= set(dce_indices(p, 0.5))


def test_radius_is_kept() -> None:
    p = _square()
    r = np.linspace(1.0, 5.0, len(p))
    out = dce(np.column_stack((p, r)), 1.0)
    assert out.shape == (5, 3)
    idx = dce_indices(p, 1.0)
    np.testing.assert_allclose(out[:, 2], r[idx])


def test_two_points_and_degenerate_arms() -> None:
    np.testing.assert_allclose(dce(np.array([[0.0, 0.0], [1.0, 1.0]]), 1.0),
                               [[0, 0], [1, 1]])
    back = np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 0.0], [0.0, 5.0]])
    assert len(dce(back, 1.0)) >= 2


def test_plugin_registered_and_makes_plans() -> None:
    init = inkmotion.plugin("initialiser", "dce")
    assert init.name == "dce" and init.description
    traces = Traces([_square(), np.column_stack((np.linspace(0, 9, 30), np.zeros(30)))])
    plans = init(JobInputs((20, 20), traces=traces), threshold=1.0, width=2.0,
                 dtype=torch.float64, bend=False)
    assert [p.m for p in plans] == [4, 1]
    p = plans[0]
    assert p.points.dtype == torch.float64 and p.width == 2.0
    torch.testing.assert_close(p.delta_t, torch.ones(4, dtype=torch.float64))
    torch.testing.assert_close(p.delta, torch.zeros(4, dtype=torch.float64))
    torch.testing.assert_close(p.ac, torch.full((4,), 0.01, dtype=torch.float64))
    torch.testing.assert_close(p.T, torch.full((4,), 0.8, dtype=torch.float64))
    with pytest.raises(SpecError, match="dce initialiser needs traces"):
        init(JobInputs((20, 20), caption="a cat"))


def test_a_long_random_walk_keeps_its_ends_and_order() -> None:
    p = np.cumsum(np.random.default_rng(2).normal(size=(5000, 2)), axis=0)
    kept = dce_indices(p, 1.0)
    assert kept[0] == 0 and kept[-1] == len(p) - 1 and np.all(np.diff(kept) > 0)
    assert 2 < len(kept) < len(p)


def _wiggle(scale: float) -> np.ndarray:
    """A wavy stroke of 400 points, ``scale`` px across."""
    t = np.linspace(0.0, 1.0, 400)
    return scale * np.column_stack((t, 0.15 * np.sin(9 * t) + 0.05 * np.sin(31 * t)))


def test_the_same_drawing_at_any_canvas_size_gets_the_same_plan() -> None:
    init = inkmotion.plugin("initialiser", "dce")
    counts = []
    for size in (350, 2000):
        traces = Traces([_wiggle(size)])
        plans = init(JobInputs((size, size), traces=traces), dtype=torch.float64)
        counts.append(plans[0].m)
        assert plans[0].points[:, 0].max() == pytest.approx(size)
    assert counts[0] == counts[1] and counts[0] > 2
    # the absolute threshold in px·rad does not scale: it keeps many more at 2000 px
    absolute = [init(JobInputs((s, s), traces=Traces([_wiggle(s)])), threshold=30.0,
                     dtype=torch.float64)[0].m for s in (350, 2000)]
    assert absolute[1] > absolute[0]


def test_relevance_is_the_authors_measure() -> None:
    """K* = relevance·2·size·π/180: a vertex of turning β° between arms l is kept when
    β·l/2 / size exceeds the relevance (their demo's measure, l1·l2/(l1+l2) = l/2)."""
    size, arm = 350.0, 40.0
    for beta, kept in ((20.0, False), (50.0, True)):  # 20·20/350 = 1.14, 50·20/350 = 2.86
        b = np.radians(beta)
        p = np.array([[0.0, 0.0], [arm, 0.0], [arm + arm * np.cos(b), arm * np.sin(b)]])
        assert (len(dce_indices(p, relevance_threshold(2.5, size))) == 3) == kept


def test_a_count_of_targets_is_met() -> None:
    strokes = [_wiggle(350), _wiggle(200) + 50]
    for n in (4, 12, 30):
        got = moves_at(strokes, threshold_for_moves(strokes, n, 350))
        assert abs(got - n) <= max(1, n // 10), (n, got)
    init = inkmotion.plugin("initialiser", "dce")
    plans = init(JobInputs((350, 350), traces=Traces(strokes), targets=12), dtype=torch.float64)
    assert abs(sum(p.m for p in plans) - 12) <= 1


@pytest.mark.parametrize("delta", [0.7, -1.2, 0.05, 0.0])
def test_initial_turns_recover_the_arc_of_a_sub_movement(delta: float) -> None:
    from inkmotion.outputs.sampling import sample
    from inkmotion.sigma_lognormal.plan import MotorPlan

    plan = MotorPlan.from_points(torch.tensor([[10.0, 20.0], [100.0, 60.0]]),
                                 delta=delta, dtype=torch.float64)
    arc = sample(plan, 400).positions
    assert initial_turns(arc, np.array([0, len(arc) - 1]))[0] == pytest.approx(delta, abs=0.01)


@pytest.mark.parametrize("delta", [2.4, -2.9])
def test_the_bend_of_a_loop_starts_past_a_quarter_circle(delta: float) -> None:
    """A script loop's sub-movement turns most of a half circle: its initial δ is the
    trace's bend, clamped to the half circle (``max_bend`` π), and to the quarter circle
    only where asked (spec 16's clamp)."""
    from inkmotion.outputs.sampling import sample
    from inkmotion.sigma_lognormal.plan import MotorPlan

    plan = MotorPlan.from_points(torch.tensor([[10.0, 20.0], [40.0, 140.0]]),
                                 delta=delta, dtype=torch.float64)
    arc = sample(plan, 400).positions
    ends = np.array([0, len(arc) - 1])
    assert initial_turns(arc, ends)[0] == pytest.approx(delta, abs=0.01)
    assert initial_turns(arc, ends, math.pi / 2)[0] == math.copysign(math.pi / 2, delta)


@pytest.mark.parametrize("delta", [1.1, -2.6, 0.2])
def test_the_fitted_arc_of_an_arc_is_that_arc(delta: float) -> None:
    from inkmotion.outputs.sampling import sample
    from inkmotion.sigma_lognormal.plan import MotorPlan

    plan = MotorPlan.from_points(torch.tensor([[10.0, 20.0], [90.0, 50.0]]), delta=delta,
                                 dtype=torch.float64)
    arc = np.asarray(sample(plan, 400).positions)
    ends = np.array([0, len(arc) - 1])
    assert fitted_turn(arc) == pytest.approx(delta, abs=0.01)
    for estimate in ("peak", "fitted", "between"):
        assert initial_turns(arc, ends, estimate=estimate)[0] == pytest.approx(delta, abs=0.01)


def test_a_piece_that_runs_straight_then_turns_starts_straighter_than_its_peak() -> None:
    """60 px straight, then a quarter circle of radius 10 px: the arc through the peak
    bulges over the whole chord as far as the turn does; the fitted arc is straighter,
    and 'between' is halfway."""
    straight = np.column_stack((np.linspace(0, 60, 61), np.zeros(61)))
    angle = np.linspace(0, math.pi / 2, 20)[1:]
    turn = np.column_stack((60 + 10 * np.sin(angle), 10 - 10 * np.cos(angle)))
    piece = np.vstack((straight, turn))
    ends = np.array([0, len(piece) - 1])
    peak, fitted, between = (initial_turns(piece, ends, estimate=e)[0]
                             for e in ("peak", "fitted", "between"))
    assert np.sign(peak) == np.sign(fitted) != 0
    assert abs(fitted) < 0.8 * abs(peak)  # 0.69 against 0.95 rad
    assert between == pytest.approx(0.5 * (peak + fitted))
    with pytest.raises(ValueError, match="estimate must be one of"):
        initial_turns(piece, ends, estimate="mean")


def test_the_dce_initialiser_clamps_the_bend_to_its_max_bend() -> None:
    from inkmotion.outputs.sampling import sample
    from inkmotion.sigma_lognormal.plan import MotorPlan

    plan = MotorPlan.from_points(torch.tensor([[10.0, 20.0], [40.0, 140.0]]), delta=2.8,
                                 dtype=torch.float64)
    stroke = np.asarray(sample(plan, 400).positions)
    init = inkmotion.plugin("initialiser", "dce")
    inputs = JobInputs((350, 350), traces=Traces([stroke]), targets=1)
    wide = init(inputs, dtype=torch.float64)
    narrow = init(inputs, dtype=torch.float64, max_bend=90.0)
    assert [p.m for p in wide] == [p.m for p in narrow] == [1]
    assert float(wide[0].delta[0]) == pytest.approx(2.8, abs=0.02)
    assert float(narrow[0].delta[0]) == pytest.approx(math.pi / 2)


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data is absent")
def test_the_authors_density_on_the_paper_tags() -> None:
    """The default relevance 2.5 keeps 29 targets' worth of sub-movements on 49867.json."""
    from inkmotion.kinds.read import read_input

    traces = read_input(str(SHARED / "49867.json")).fit_to_canvas(350).validated()
    assert moves_at(traces.strokes, relevance_threshold(2.5, 350)) == 29
