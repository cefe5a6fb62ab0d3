"""DCE initialiser: salient points of simple shapes, monotonicity, radius, registration."""

import numpy as np
import pytest
import torch

import inkmotion
from inkmotion.errors import SpecError
from inkmotion.geometry.traces import Traces
from inkmotion.plugin_host.protocols import JobInputs
from inkmotion.plugins.dce import dce, dce_indices


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
                 dtype=torch.float64)
    assert [p.m for p in plans] == [4, 1]
    p = plans[0]
    assert p.points.dtype == torch.float64 and p.width == 2.0
    torch.testing.assert_close(p.delta_t, torch.ones(4, dtype=torch.float64))
    torch.testing.assert_close(p.delta, torch.zeros(4, dtype=torch.float64))
    torch.testing.assert_close(p.ac, torch.full((4,), 0.01, dtype=torch.float64))
    torch.testing.assert_close(p.T, torch.full((4,), 0.8, dtype=torch.float64))
    with pytest.raises(SpecError, match="dce initialiser needs traces"):
        init(JobInputs((20, 20), caption="a cat"))


@pytest.mark.parametrize("n", [5000])
def test_long_stroke_is_fast(n: int) -> None:
    import time

    p = np.cumsum(np.random.default_rng(2).normal(size=(n, 2)), axis=0)
    t = time.perf_counter()
    dce(p, 1.0)
    assert time.perf_counter() - t < 2.0
