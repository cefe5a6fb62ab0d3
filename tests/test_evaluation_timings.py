"""Three timings of the same path under the same limits (paper, section "Evaluation"): the ΣΛ
plan's own, path-constrained minimum jerk and time-optimal (TOPP-RA).

Limits are checked by finite differences of the sampled positions: the first difference is
the mean velocity over a period and the second the hat-weighted mean acceleration over two,
so neither can exceed the continuous peak; ``TOL`` (0.1 %) allows for rounding. The
methods' own velocity and acceleration samples are checked too.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from scipy.spatial import cKDTree

from inkmotion.evaluation.minjerk import evaluate_spline, minimum_jerk_timing, passage_times
from inkmotion.evaluation.time_optimal import DIRECTIONS, time_optimal_timing
from inkmotion.evaluation.timings import TimedPath, sigma_lognormal_timing, via_points
from inkmotion.sigma_lognormal import MotorPlan
from inkmotion.sigma_lognormal.kinematics import kinematics

V_MAX, A_MAX, RATE = 200.0, 2000.0, 1000.0  # px/s, px/s², Hz
TOL = 1e-3
#: a timed path keeps within this distance (px) of the ΣΛ path
PATH_TOL = 0.05

PLANS = {
    "curve": MotorPlan.from_points([[0, 0], [100, 30], [200, 0], [250, 80]], delta=0.6,
                                   dtype=torch.float64),
    "zigzag": MotorPlan.from_points([[0, 0], [60, 40], [20, 90], [120, 100], [100, 20]],
                                    delta=-0.4, delta_t=0.6, dtype=torch.float64),
}


def _timings(plan: MotorPlan) -> dict[str, TimedPath]:
    sigma = sigma_lognormal_timing(plan, V_MAX, A_MAX, RATE)
    return {"sigma-lognormal": sigma,
            "minimum-jerk": minimum_jerk_timing(sigma.position, V_MAX, A_MAX, RATE),
            "time-optimal": time_optimal_timing(sigma.position, V_MAX, A_MAX, RATE)}


@pytest.fixture(scope="module", params=sorted(PLANS))
def timed(request: pytest.FixtureRequest) -> tuple[MotorPlan, dict[str, TimedPath]]:
    plan = PLANS[request.param]
    return plan, _timings(plan)


def _dense_path(plan: MotorPlan, t_a: float, t_b: float, n: int = 200_000) -> np.ndarray:
    """The exact ΣΛ path at n plan times over [t_a, t_b] (n, 2)."""
    with torch.no_grad():
        x = kinematics(plan, torch.linspace(t_a, t_b, n, dtype=torch.float64))[0]
    return x[:, :2].numpy()


def test_uniform_samples_and_shapes(timed: tuple[MotorPlan, dict[str, TimedPath]]) -> None:
    for name, path in timed[1].items():
        n = len(path.t)
        assert path.method == name
        np.testing.assert_allclose(path.t, np.arange(n) / RATE, atol=1e-12)
        for a in (path.position, path.velocity, path.acceleration, path.jerk):
            assert a is not None and a.shape == (n, 2) and np.isfinite(a).all()


def test_same_path(timed: tuple[MotorPlan, dict[str, TimedPath]]) -> None:
    plan, paths = timed
    dense = _dense_path(plan, *paths["sigma-lognormal"].info["support"])
    tree = cKDTree(dense)
    for name, path in paths.items():
        gap = tree.query(path.position)[0].max()
        assert gap < PATH_TOL, (name, gap)
        np.testing.assert_allclose(path.position[[0, -1]], dense[[0, -1]], atol=1e-3)


def test_limits_and_rest(timed: tuple[MotorPlan, dict[str, TimedPath]]) -> None:
    for name, path in timed[1].items():
        dt = 1.0 / RATE
        fd_speed = np.linalg.norm(np.diff(path.position, axis=0), axis=1) / dt
        fd_acc = np.linalg.norm(np.diff(path.position, 2, axis=0), axis=1) / dt**2
        assert fd_speed.max() <= V_MAX * (1 + TOL), name
        assert fd_acc.max() <= A_MAX * (1 + TOL), name
        assert np.linalg.norm(path.velocity, axis=1).max() <= V_MAX * (1 + 1e-9), name
        assert np.linalg.norm(path.acceleration, axis=1).max() <= A_MAX * (1 + 1e-9), name
        ends = np.linalg.norm(path.velocity[[0, -1]], axis=1)
        assert ends.max() < 1e-3 * V_MAX, (name, ends)


def test_time_optimal_is_fastest_and_tight(
        timed: tuple[MotorPlan, dict[str, TimedPath]]) -> None:
    paths = timed[1]
    optimal = paths["time-optimal"]
    for name in ("sigma-lognormal", "minimum-jerk"):
        assert optimal.duration < paths[name].duration, name
    for name, path in paths.items():  # each timing touches a limit
        speed = np.linalg.norm(path.velocity, axis=1).max() / V_MAX
        acc = np.linalg.norm(path.acceleration, axis=1).max() / A_MAX
        assert max(speed, acc) > (0.95 if name == "time-optimal" else 0.99), name


def test_minimum_jerk_on_a_line_is_the_quintic() -> None:
    """A straight path: the minimum-jerk timing is s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (Flash & Hogan
    1985), whatever the via points."""
    end = np.array([120.0, -50.0])
    line = np.linspace(0.0, 1.0, 2001)[:, None] ** 1.5 * end  # unevenly sampled
    path = minimum_jerk_timing(line, V_MAX, A_MAX, RATE, spacing=10.0)
    s = path.position @ end / (end @ end)
    tau = path.t / path.duration
    quintic = tau**3 * (10 - 15 * tau + 6 * tau**2)
    assert np.abs(s - quintic).max() < 1e-3
    length = float(np.linalg.norm(end))
    expected = max(15 / 8 * length / V_MAX, math.sqrt(10 / math.sqrt(3) * length / A_MAX))
    assert path.duration == pytest.approx(expected, abs=2.0 / RATE)


def test_minimum_jerk_spline_is_c4_and_its_jerk_is_exact() -> None:
    """At the optimal durations the spline is C⁴ at the via points (Euler–Lagrange), and its
    analytic jerk matches the finite difference of its acceleration."""
    points = np.array([[0, 0], [30, 10], [50, 40], [40, 70], [70, 90]], dtype=float)
    h, values, _ = passage_times(points)
    knots = np.cumsum(h)[:-1]
    eps = 1e-7
    for order in range(4):
        left = evaluate_spline(h, values, knots - eps)[order]
        right = evaluate_spline(h, values, knots + eps)[order]
        scale = np.abs(evaluate_spline(h, values, np.linspace(0, 1, 500))[order]).max()
        np.testing.assert_allclose(left, right, atol=1e-4 * scale)
    t = np.cumsum(h) - h / 2  # mid-piece: the jerk is exact there, whatever the knots
    _, _, a_plus, _ = evaluate_spline(h, values, t + 1e-6)
    _, _, a_minus, j = evaluate_spline(h, values, t - 1e-6)
    np.testing.assert_allclose((a_plus - a_minus) / 2e-6, j, rtol=1e-4,
                               atol=1e-6 * np.abs(j).max())


def test_time_optimal_on_a_line_is_bang_coast_bang() -> None:
    """A straight move of length L from rest to rest: accelerate at a, cruise at v_max,
    brake: T = L/v_max + v_max/a, with a the polygon's bound along the x axis."""
    length = 100.0
    line = np.column_stack((np.linspace(0.0, length, 501), np.zeros(501)))
    path = time_optimal_timing(line, V_MAX, A_MAX, RATE)
    a = A_MAX * math.cos(math.pi / DIRECTIONS)
    assert path.duration == pytest.approx(length / V_MAX + V_MAX / a, rel=5e-3)


def test_via_points_follow_the_polyline() -> None:
    theta = np.linspace(0.0, 1.5 * np.pi, 3001)
    arc = 50.0 * np.column_stack((np.cos(theta), np.sin(theta)))
    points = via_points(np.concatenate((arc[:1], arc)), spacing=5.0, max_turn=1.0)
    np.testing.assert_allclose(points[[0, -1]], arc[[0, -1]])
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    assert steps.max() <= 5.0 + 1e-9
    np.testing.assert_allclose(np.linalg.norm(points, axis=1), 50.0, atol=1e-3)
