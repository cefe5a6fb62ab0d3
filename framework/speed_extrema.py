"""Speed peaks and minima of a uniformly sampled speed profile: where a stroke's bell peaks,
and where the pen slows down (the paper's Fig. 3c/d).

One module below both users: :mod:`inkmotion.evaluation.metrics` counts them, and the spray
preview (:mod:`inkmotion.rendering.spray_preview`) pools paint at the minima; with the
functions here neither imports the other. NumPy only, and SciPy's ndimage for smoothing.

Method: the peaks of ``scipy.signal.find_peaks`` on the speed (or its negative) with a
prominence of ``prominence`` × the peak speed, after an optional Gaussian smoothing of
``smooth_s`` seconds (for noisy recordings). :func:`find_peaks` is that function's
definition of a peak and of its prominence written with NumPy (a test checks it against
SciPy's on random profiles): importing ``scipy.signal`` costs about 0.9 s here, a third of
a default fit's job time, for one call per fit.
"""

from __future__ import annotations

import numpy as np


def local_maxima(x: np.ndarray) -> np.ndarray:
    """Indices of the local maxima of ``x`` (N,) as ``scipy.signal.find_peaks`` finds them:
    a sample (or the middle of a flat run, rounded down) higher than the samples on both
    sides of it; never the first or last sample, nor a flat run touching either end."""
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    if n < 3:
        return np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.concatenate(([True], x[1:] != x[:-1])))  # runs of equals
    ends = np.concatenate((starts[1:] - 1, [n - 1]))
    values = x[starts]
    higher_left = np.concatenate(([False], values[1:] > values[:-1]))
    higher_right = np.concatenate((values[:-1] > values[1:], [False]))
    peak = higher_left & higher_right & (starts > 0) & (ends < n - 1)
    return ((starts[peak] + ends[peak]) // 2).astype(np.int64)


def prominences(x: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """The prominence of each peak of ``x``, as ``scipy.signal.peak_prominences`` (no window):
    its height above the higher of the lowest points on either side before the signal
    rises above the peak (or ends)."""
    x = np.asarray(x, dtype=np.float64)
    out = np.empty(len(peaks))
    for k, p in enumerate(peaks):
        above = np.flatnonzero(x[:p] > x[p])
        left = x[(above[-1] + 1 if len(above) else 0):p + 1].min()
        above = np.flatnonzero(x[p + 1:] > x[p])
        right = x[p:(p + 1 + above[0] if len(above) else len(x))].min()
        out[k] = x[p] - max(left, right)
    return out


def find_peaks(x: np.ndarray, prominence: float) -> tuple[np.ndarray, dict]:
    """``scipy.signal.find_peaks(x, prominence=prominence)`` (a minimum prominence only):
    the local maxima whose prominence is at least ``prominence``, and their prominences
    (``{"prominences": …}``), as SciPy returns them."""
    peaks = local_maxima(x)
    prom = prominences(x, peaks)
    keep = prom >= prominence
    return peaks[keep], {"prominences": prom[keep]}


def smoothed(values: np.ndarray, dt: float, smooth_s: float) -> np.ndarray:
    """``values`` (N,) sampled every ``dt`` s after a Gaussian of standard deviation
    ``smooth_s`` seconds (0: unchanged, as float64)."""
    values = np.asarray(values, dtype=np.float64)
    if smooth_s <= 0:
        return values
    from scipy.ndimage import gaussian_filter1d

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
