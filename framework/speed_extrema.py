"""Speed peaks and minima of a uniformly sampled speed profile: where a stroke's bell peaks,
and where the pen slows down (the paper's Fig. 3c/d).

One module below both users: :mod:`inkmotion.evaluation.metrics` counts them, and the spray
preview (:mod:`inkmotion.rendering.spray_preview`) pools paint at the minima; with the
functions here neither imports the other. Numpy and scipy only.

Method: ``scipy.signal.find_peaks`` on the speed (or its negative) with a prominence of
``prominence`` × the peak speed, after an optional Gaussian smoothing of ``smooth_s``
seconds (for noisy recordings).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import find_peaks


def smoothed(values: np.ndarray, dt: float, smooth_s: float) -> np.ndarray:
    """``values`` (N,) sampled every ``dt`` s after a Gaussian of standard deviation
    ``smooth_s`` seconds (0: unchanged, as float64)."""
    values = np.asarray(values, dtype=np.float64)
    if smooth_s <= 0:
        return values
    return gaussian_filter1d(values, smooth_s / dt, mode="nearest")


def speed_peaks(speed: np.ndarray, dt: float, *, smooth_s: float = 0.0,
                prominence: float = 0.05) -> np.ndarray:
    """Indices of the local maxima of ``speed`` (N,) whose prominence is at least
    ``prominence`` × the peak speed, after a Gaussian smoothing of standard deviation
    ``smooth_s`` seconds (0: none). A bell-shaped stroke has one."""
    s = smoothed(speed, dt, smooth_s)
    top = float(np.max(s)) if len(s) else 0.0
    if top <= 0:
        return np.zeros(0, dtype=np.int64)
    return find_peaks(s, prominence=prominence * top)[0].astype(np.int64)


def speed_minima(speed: np.ndarray, dt: float, *, smooth_s: float = 0.0,
                 prominence: float = 0.05) -> np.ndarray:
    """Indices of the interior local minima of ``speed`` (N,) with prominence at least
    ``prominence`` × the peak speed (the rest at both ends is not a minimum)."""
    s = smoothed(speed, dt, smooth_s)
    top = float(np.max(s)) if len(s) else 0.0
    if top <= 0:
        return np.zeros(0, dtype=np.int64)
    return find_peaks(-s, prominence=prominence * top)[0].astype(np.int64)
