"""The one limit-ratio computation (:mod:`inkmotion.robot.limits`): its finite differences
are exact on polynomials of their order, and the planner's and the simulation's figures of
the same trajectory agree."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from inkmotion.robot import limits


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-10, 10), min_size=4, max_size=4), st.sampled_from([1, 2, 3]))
def test_the_nth_difference_is_exact_on_a_polynomial_of_degree_n(coeffs: list[float],
                                                                  order: int) -> None:
    rate = 100.0
    t = np.arange(50) / rate
    poly = np.polynomial.Polynomial(coeffs[:order + 1])
    d = limits.finite_difference(poly(t)[:, None], rate, order)
    assert d.shape == (50 - order, 1)
    np.testing.assert_allclose(d[:, 0], poly.deriv(order)(t[:len(d)] + order / (2 * rate)),
                               atol=1e-6 * rate**order)


def test_ratios_are_peaks_over_the_datasheet_limits() -> None:
    rate = 1000.0
    t = np.arange(200) / rate
    q = np.outer(t, 0.5 * limits.VELOCITY_LIMITS)  # (N, 7): every joint at half its limit
    ratios = limits.joint_limit_ratios(q, rate)
    np.testing.assert_allclose(ratios["velocity"], 0.5)
    np.testing.assert_allclose(ratios["acceleration"], 0.0, atol=1e-9)
    figures = limits.limit_figures("v", 0.5 * limits.VELOCITY_LIMITS, limits.VELOCITY_LIMITS)
    assert figures["v_min_margin"] == 0.5


def test_too_short_a_trajectory_has_zero_peaks() -> None:
    q = np.zeros((2, 7))
    assert np.all(limits.joint_limit_ratios(q, 1000.0)["jerk"] == 0)
    assert limits.peak_norm(np.zeros((2, 3)), 1000.0, 2) == 0.0
