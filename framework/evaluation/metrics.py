"""Speed, smoothness and curvature metrics of one uniformly sampled trajectory (paper, section
"Evaluation", and the speed minima of Fig. 3c/d).

Input. ``position`` is (N, D) with D = 2 or 3, sampled every ``dt`` seconds (times
t_k = t_0 + k·dt; :func:`uniform_step` gets dt from such times). Only the planar (x, y)
coordinates enter speed, jerk and curvature: the radius of a 2.5D plan does not move the pen
along the paper. Units are the caller's (px and s, or m and s); LDJ is dimensionless.

Derivatives. Velocity, acceleration and jerk are taken by ``numpy.gradient`` (central
differences inside, second-order one-sided at the ends), each from the previous one, unless
the caller passes exact derivative arrays (the ΣΛ kinematics gives velocity and acceleration
in closed form; then only one numerical derivative, :func:`jerk_from`, remains). Integrals
over [0, T] use the trapezoid rule on the samples.

Definitions.

- Mean squared jerk (Hogan & Sternad 2007, "On rhythmic and discrete movements: reflections,
  definitions and implications for motor control"): MSJ = (1/T)·∫_0^T |d³x/dt³|² dt, the
  plain time average of the squared jerk norm — *no* factor ½ (the ½ of the minimum-jerk cost
  cancels in every ratio anyway). Units: length²/s⁶. It scales as A²/T⁶ (amplitude A,
  duration T), so it only compares movements of the same path and duration class.
- Log dimensionless jerk (Balasubramanian, Melendez-Calderon, Roby-Brami & Burdet 2015,
  "On the analysis of movement smoothness", J. NeuroEng. Rehabil. 12:112, eq. for LDJ):

      LDJ = −ln( (T³ / v_peak²) · ∫_0^T |d³x/dt³|² dt ),

  with v_peak the peak speed. The velocity-peak normalisation makes it invariant to spatial
  scale and to duration (Hogan & Sternad 2009 normalise by T⁵/A² with the amplitude A instead;
  that variant is not used here). LDJ is negative; larger (nearer 0) is smoother. A minimum
  jerk point-to-point movement has ∫x⃛² = 720A²/T⁵ and v_peak = 15A/(8T), so
  LDJ = −ln(720·64/225) = −ln 204.8 ≈ −5.322.
- Curvature of a planar curve: κ = |ẋÿ − ẏẍ| / |v|³ (1/R on a circle of radius R).
- Speed peaks and minima: SciPy's ``find_peaks`` (written with NumPy in
  :mod:`inkmotion.speed_extrema`) on the speed (or its negative) with a prominence of
  ``prominence`` × the peak speed, after an optional Gaussian smoothing of ``smooth_s``
  seconds (for noisy recordings); :func:`speed_peaks` and :func:`speed_minima`
  live in :mod:`inkmotion.speed_extrema`, below the spray preview that needs them too.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from inkmotion.speed_extrema import find_peaks, speed_minima, speed_peaks

#: curvature below this over the path's extent (a radius 1000× the drawing) is straight
STRAIGHT = 1e-3
#: speeds below this fraction of the peak speed count as "at rest" (curvature is undefined)
REST_FRACTION = 0.01


def uniform_step(t: np.ndarray, rtol: float = 1e-6) -> float:
    """The sampling step dt of uniform times ``t`` (N ≥ 2); refuses non-uniform times."""
    t = np.asarray(t, dtype=np.float64)
    steps = np.diff(t)
    dt = float(steps.mean())
    if len(t) < 2 or dt <= 0 or np.max(np.abs(steps - dt)) > rtol * max(abs(dt), 1e-300):
        raise ValueError("the times are not uniformly sampled and increasing")
    return dt


def duration(t: np.ndarray) -> float:
    """T = t_last − t_first of the sample times ``t`` (N,)."""
    t = np.asarray(t, dtype=np.float64)
    return float(t[-1] - t[0])


def _planar(position: np.ndarray) -> np.ndarray:
    return np.asarray(position, dtype=np.float64)[:, :2]


def _derivative(values: np.ndarray, dt: float) -> np.ndarray:
    """d/dt along axis 0 by central differences (second-order one-sided at the ends)."""
    return np.gradient(values, dt, axis=0, edge_order=2)


def planar_velocity(position: np.ndarray, dt: float) -> np.ndarray:
    """(N, 2) planar velocity of ``position`` (N, D) sampled every ``dt`` s."""
    return _derivative(_planar(position), dt)


def speed(position: np.ndarray, dt: float) -> np.ndarray:
    """(N,) planar speed |(ẋ, ẏ)| of ``position`` (N, D) sampled every ``dt`` s."""
    return np.linalg.norm(planar_velocity(position, dt), axis=1)


def peak_speed(position: np.ndarray, dt: float) -> float:
    """max_t |v(t)|: the largest planar speed of the samples."""
    return float(speed(position, dt).max())


def jerk_from(acceleration: np.ndarray, dt: float) -> np.ndarray:
    """(N, 2) planar jerk d³x/dt³ as the numerical derivative of exact accelerations."""
    return _derivative(_planar(acceleration), dt)


def jerk(position: np.ndarray, dt: float) -> np.ndarray:
    """(N, 2) planar jerk d³x/dt³ from position alone (N ≥ 5).

    Third differences Δ³x/dt³ are second-order estimates at the half-way times
    t_{k+3/2}; they are linearly interpolated onto the sample times (and extrapolated by
    1.5 steps at each end). Three nested ``numpy.gradient`` calls would be only first-order
    accurate at the ends, which biases the jerk integral by O(dt)."""
    x = _planar(position)
    if len(x) < 5:
        raise ValueError("the jerk needs at least 5 samples")
    mid = np.diff(x, n=3, axis=0) / dt**3  # at k + 1.5, k = 0..N-4
    k = np.arange(len(x), dtype=np.float64)
    where = np.arange(len(mid), dtype=np.float64) + 1.5
    out = np.stack([np.interp(k, where, mid[:, d]) for d in range(x.shape[1])], axis=1)
    for i in (0, 1):  # linear extrapolation through the two nearest half-way values
        out[i] = mid[0] + (i - 1.5) * (mid[1] - mid[0])
        out[-1 - i] = mid[-1] + (1.5 - i) * (mid[-1] - mid[-2])
    return out


def _squared_jerk_integral(position: np.ndarray, dt: float,
                           acceleration: np.ndarray | None) -> float:
    """∫_0^T |d³x/dt³|² dt (trapezoid rule)."""
    j = jerk(position, dt) if acceleration is None else jerk_from(acceleration, dt)
    return float(np.trapezoid(np.sum(j * j, axis=1), dx=dt))


def msj(position: np.ndarray, dt: float, *, acceleration: np.ndarray | None = None) -> float:
    """Mean squared jerk (Hogan & Sternad 2007): (1/T)·∫_0^T |d³x/dt³|² dt, no factor ½.

    The jerk comes from ``acceleration`` (N, D) when given, else from ``position``."""
    T = (len(position) - 1) * dt
    return _squared_jerk_integral(position, dt, acceleration) / T


def ldj(position: np.ndarray, dt: float, *, velocity: np.ndarray | None = None,
        acceleration: np.ndarray | None = None) -> float:
    """Log dimensionless jerk (Balasubramanian et al. 2015):
    LDJ = −ln((T³ / v_peak²)·∫_0^T |d³x/dt³|² dt). Negative; nearer 0 is smoother.

    v_peak comes from ``velocity`` (N, D) when given, the jerk from ``acceleration``."""
    T = (len(position) - 1) * dt
    v = _planar(velocity) if velocity is not None else planar_velocity(position, dt)
    v_peak = float(np.linalg.norm(v, axis=1).max())
    integral = _squared_jerk_integral(position, dt, acceleration)
    return float(-np.log(T**3 / v_peak**2 * integral))


def curvature(position: np.ndarray, dt: float) -> np.ndarray:
    """(N,) unsigned curvature κ = |ẋÿ − ẏẍ| / |v|³ of the planar path (1/length).

    Samples at rest (speed below :data:`REST_FRACTION` of the peak) get NaN: the direction,
    and so the curvature, is undefined there."""
    v = planar_velocity(position, dt)
    a = _derivative(v, dt)
    s = np.linalg.norm(v, axis=1)
    cross = np.abs(v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0])
    floor = REST_FRACTION * float(s.max())
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = cross / s**3
    return np.where(s > floor, kappa, np.nan)


def curvature_maxima(kappa: np.ndarray, *, prominence: float = 0.5,
                     floor: float = 0.0) -> np.ndarray:
    """Indices of the local maxima of the curvature ``kappa`` (N,) whose prominence in
    ln κ is at least ``prominence`` (0.5: the peak is e^0.5 ≈ 1.65 × its surroundings).

    Log scale, because curvature spans decades (near-straight runs, sharp corners); values
    below ``floor`` count as straight (without one, the rounding noise of a straight line
    would have peaks). Rest samples (NaN) split the curve: no maximum is found at them."""
    moving = np.isfinite(kappa)
    if not moving.any():
        return np.zeros(0, dtype=np.int64)
    logk = np.log(np.maximum(np.where(moving, kappa, 1.0), max(floor, 1e-300)))
    logk = np.where(moving, logk, logk[moving].min())
    peaks = find_peaks(logk, prominence=prominence)[0]
    # a neighbour at rest means the "peak" is only the edge of a rest interval
    ok = moving[peaks] & moving[np.maximum(peaks - 1, 0)]
    ok &= moving[np.minimum(peaks + 1, len(logk) - 1)]
    return peaks[ok].astype(np.int64)


def _matched_fraction(a: np.ndarray, b: np.ndarray, window: int) -> float | None:
    """Share of indices in ``a`` that have an index of ``b`` within ``window`` samples."""
    if len(a) == 0:
        return None
    if len(b) == 0:
        return 0.0
    gaps = np.abs(a[:, None] - b[None, :]).min(axis=1)
    return float(np.mean(gaps <= window))


def speed_minima_at_curvature_maxima(position: np.ndarray, dt: float, *,
                                     window_s: float = 0.05, speed_prominence: float = 0.05,
                                     curvature_prominence: float = 0.5,
                                     smooth_s: float = 0.0) -> dict[str, Any]:
    """How well speed minima and curvature maxima coincide (the paper's Fig. 3c/d: the pen
    slows down where the path bends).

    A curvature maximum (:func:`curvature_maxima`) is matched when a speed minimum
    (:func:`speed_minima`) lies within ``window_s`` seconds of it, and vice versa; curvature
    below :data:`STRAIGHT` / (the path's extent) is treated as straight. Returns
    the counts, both matched fractions (None when there is nothing to match), the median
    lag t_minimum − t_maximum of the nearest pairs (s) and the window."""
    s = speed(position, dt)
    minima = speed_minima(s, dt, smooth_s=smooth_s, prominence=speed_prominence)
    xy = _planar(position)
    extent = float(np.max(xy.max(axis=0) - xy.min(axis=0)))
    floor = STRAIGHT / extent if extent > 0 else np.inf
    maxima = curvature_maxima(curvature(position, dt), prominence=curvature_prominence,
                              floor=floor)
    window = int(round(window_s / dt))
    lag = None
    if len(minima) and len(maxima):
        nearest = minima[np.abs(maxima[:, None] - minima[None, :]).argmin(axis=1)]
        lag = float(np.median(nearest - maxima) * dt)
    return {
        "curvature_maxima": int(len(maxima)),
        "speed_minima": int(len(minima)),
        "curvature_maxima_with_speed_minimum": _matched_fraction(maxima, minima, window),
        "speed_minima_with_curvature_maximum": _matched_fraction(minima, maxima, window),
        "median_lag_s": lag,
        "window_s": float(window_s),
    }


def trajectory_metrics(position: np.ndarray, dt: float, *, velocity: np.ndarray | None = None,
                       acceleration: np.ndarray | None = None,
                       prominence: float = 0.05) -> dict[str, float]:
    """Duration (s), peak speed, number of speed peaks, MSJ and LDJ of one trajectory
    (definitions in the module docstring); exact ``velocity``/``acceleration`` arrays are
    used when given."""
    v = _planar(velocity) if velocity is not None else planar_velocity(position, dt)
    s = np.linalg.norm(v, axis=1)
    return {
        "duration": (len(position) - 1) * dt,
        "peak_speed": float(s.max()),
        "speed_peaks": int(len(speed_peaks(s, dt, prominence=prominence))),
        "msj": msj(position, dt, acceleration=acceleration),
        "ldj": ldj(position, dt, velocity=v, acceleration=acceleration),
    }
