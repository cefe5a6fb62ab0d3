"""Chamfer / Hausdorff distance between polyline sets."""

import numpy as np
import pytest

from inkmotion.geometry.chamfer import chamfer, densify


def test_identical_is_zero() -> None:
    a = [np.array([[0.0, 0.0], [10.0, 3.0], [20.0, -1.0]]), np.array([[5.0, 5.0], [6.0, 9.0]])]
    assert chamfer(a, [p.copy() for p in a]) == (0.0, 0.0)


def test_parallel_lines_two_px_apart() -> None:
    a = [np.array([[0.0, 0.0], [100.0, 0.0]])]
    b = [np.array([[0.0, 2.0], [100.0, 2.0]])]
    mean, worst = chamfer(a, b)
    assert mean == pytest.approx(2.0)
    assert worst == pytest.approx(2.0)


def test_asymmetric_extent_and_radius_column_ignored() -> None:
    a = [np.array([[0.0, 0.0, 3.0], [10.0, 0.0, 3.0]])]
    b = [np.array([[0.0, 0.0], [20.0, 0.0]])]
    mean, worst = chamfer(a, b, spacing=0.1)
    assert worst == pytest.approx(10.0)
    # a -> b: 0; b -> a: half the points are 0..10 px away (mean 5) -> 2.5; overall 1.25
    assert mean == pytest.approx(1.25, abs=0.02)


def test_densify_spacing() -> None:
    p = densify(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 2.0]]), 0.25)
    steps = np.hypot(*np.diff(p, axis=0).T)
    assert steps.max() <= 0.25 + 1e-12
    np.testing.assert_allclose(p[[0, -1]], [[0, 0], [1, 2]])
    assert len(p) == 4 + 8 + 1
