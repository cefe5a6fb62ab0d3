"""The NumPy peak finder of :mod:`inkmotion.speed_extrema` is SciPy's ``find_peaks`` with a
minimum prominence: the same peaks and prominences on random profiles, plateaus included."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import find_peaks as scipy_find_peaks

from inkmotion.speed_extrema import find_peaks


def _same(x: np.ndarray, prominence: float) -> None:
    ours, ours_props = find_peaks(x, prominence)
    theirs, props = scipy_find_peaks(x, prominence=prominence)
    assert ours.tolist() == theirs.tolist()
    assert np.allclose(ours_props["prominences"], props["prominences"])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.integers(0, 6), min_size=0, max_size=60), st.sampled_from([0, 0.5, 1, 3]))
def test_the_same_peaks_as_scipy_on_profiles_with_plateaus(values, prominence):
    _same(np.asarray(values, dtype=np.float64), prominence)


@pytest.mark.parametrize("seed", range(5))
def test_the_same_peaks_as_scipy_on_smooth_speed_profiles(seed):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4, 4000)
    speed = sum(a * np.exp(-0.5 * ((t - c) / w) ** 2)
                for a, c, w in zip(rng.uniform(0.2, 1, 9), rng.uniform(0, 4, 9),
                                   rng.uniform(0.05, 0.4, 9), strict=True))
    for prominence in (0.0, 0.02, 0.05 * speed.max()):
        _same(speed, prominence)
        _same(-speed, prominence)
