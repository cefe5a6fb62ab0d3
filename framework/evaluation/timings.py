"""Timings of one path under the same limits (paper, section "Evaluation"): the ΣΛ plan's own
timing here, path-constrained minimum jerk in :mod:`inkmotion.evaluation.minjerk`, the
time-optimal timing in :mod:`inkmotion.evaluation.time_optimal`. Each is a
:class:`TimedPath` sampled at the control rate, rest to rest, with |v| ≤ v_max and
|a| ≤ a_max (norms of the planar pen velocity and acceleration).

The limits are unit-agnostic: pass the path in px with v_max in px/s and a_max in px/s²
(or everything in metres). Only the planar (x, y) coordinates are timed; the radius of a
2.5D plan is ignored (it does not move the pen along the paper).

Shared conventions. A timing that is free to be slowed down (ΣΛ, minimum jerk) is first
scaled uniformly, t_robot = k·t (speed ÷ k, acceleration ÷ k²), with the smallest k that
keeps its measured peaks within ``SAFETY`` of the limits
(:func:`inkmotion.robot.timing.time_scale`: k = max(peak v / v_max, sqrt(peak a / a_max))).
Every duration is then rounded up to a whole number n of control periods by a further
uniform stretch (≤ 1/rate in total, which only lowers the peaks), so the samples are
t_j = j/rate, j = 0..n, the last one at rest at the end of the path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch

from inkmotion.robot.timing import time_scale
from inkmotion.sigma_lognormal.kinematics import kinematics
from inkmotion.sigma_lognormal.plan import MotorPlan
from inkmotion.sigma_lognormal.support import support

#: fraction of v_max and a_max the measured peaks are scaled to (a peak between grid points)
SAFETY = 0.999
#: half-step (plan s) of the central difference of the exact ΣΛ acceleration (the jerk)
JERK_STEP = 1e-5


@dataclass(frozen=True)
class TimedPath:
    """One timing of a planar path, sampled uniformly at t_j = j/rate.

    ``t`` (N,) s; ``position``, ``velocity``, ``acceleration`` (N, 2) in the path's units
    per s, s², and ``jerk`` (N, 2) per s³ (None where a method has none); ``method`` names
    the timing; ``info`` holds its figures (time scale, limiting constraint, solver data).
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray | None
    method: str
    info: dict = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """The last sample's time (s)."""
        return float(self.t[-1])

    @property
    def rate(self) -> float:
        """Samples per second."""
        return (len(self.t) - 1) / self.duration if len(self.t) > 1 else float("nan")


def control_samples(duration: float, rate: float) -> tuple[np.ndarray, float]:
    """Times t_j = j/rate, j = 0..n, with n = ⌈duration·rate⌉ ≥ 1, and the stretch
    n/(rate·duration) ≥ 1 that maps ``duration`` onto n/rate."""
    n = max(1, math.ceil(duration * rate - 1e-9))
    return np.arange(n + 1) / rate, n / (rate * duration) if duration > 0 else 1.0


def peaks(velocity: np.ndarray, acceleration: np.ndarray) -> tuple[float, float]:
    """max |v| and max |a| (row norms) over samples (n, D)."""
    return (float(np.linalg.norm(velocity, axis=1).max(initial=0.0)),
            float(np.linalg.norm(acceleration, axis=1).max(initial=0.0)))


def _via_measure(path: np.ndarray, spacing: float, max_turn: float,
                 min_spacing: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples of ``path`` kept (a mask (N,)), them (K, 2) and the measure (K,) that
    :func:`via_points` spaces uniformly."""
    min_spacing = spacing / 16.0 if min_spacing is None else min_spacing
    path = np.asarray(path, dtype=float)[:, :2]
    step = np.diff(path, axis=0)
    length = np.linalg.norm(step, axis=1)
    keep = np.concatenate(([True], length > 1e-12 * max(1.0, float(np.abs(path).max()))))
    kept = path[keep]
    if len(kept) < 2:
        return keep, kept, np.zeros(len(kept))
    step = np.diff(kept, axis=0)
    length = np.linalg.norm(step, axis=1)
    heading = np.unwrap(np.arctan2(step[:, 1], step[:, 0]))
    turn = np.abs(np.diff(heading))  # at the inner vertices, split onto both sides
    turning = np.concatenate(([0.0], turn / 2)) + np.concatenate((turn / 2, [0.0]))
    dc = length / spacing + np.minimum(turning / max_turn, length / min_spacing)
    return keep, kept, np.concatenate(([0.0], np.cumsum(dc)))


def via_points(path: np.ndarray, spacing: float, max_turn: float,
               min_spacing: float | None = None) -> np.ndarray:
    """Points (M, 2) on the polyline ``path`` (N, 2), ends included, spaced uniformly in the
    measure dc = ds/spacing + min(dθ/max_turn, ds/min_spacing) (s arc length, θ the
    turning angle in rad): at most ``spacing`` apart along the path and at most
    ``max_turn`` of turning apart, so bends get more points, but about ``min_spacing``
    (default spacing/16) apart at least, so a near-cusp does not get a cluster. Repeated
    samples (a path at rest) are dropped."""
    return via_points_and_times(path, None, spacing, max_turn, min_spacing)[0]


def via_points_and_times(path: np.ndarray, times: np.ndarray | None, spacing: float,
                         max_turn: float, min_spacing: float | None = None
                         ) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`via_points` of ``path`` and, when the path's samples have ``times`` (N,),
    the time at which the path passes each via point (interpolated the same way)."""
    keep, kept, measure = _via_measure(path, spacing, max_turn, min_spacing)
    if len(kept) < 2:
        return kept[[0, 0]], None if times is None else np.asarray(times)[[0, 0]]
    m = max(2, math.ceil(measure[-1]) + 1)
    targets = np.linspace(0.0, measure[-1], m)
    points = np.column_stack([np.interp(targets, measure, kept[:, i]) for i in range(2)])
    if times is None:
        return points, None
    return points, np.interp(targets, measure, np.asarray(times, dtype=float)[keep])


def _planar(plan: MotorPlan, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """Exact (x, y) positions, velocities and accelerations (n, 2) at plan times ``t``."""
    with torch.no_grad():
        kin = kinematics(plan, torch.as_tensor(t, dtype=torch.float64))
    return tuple(k[:, :2].numpy() for k in kin)


def sigma_lognormal_timing(plan: MotorPlan, v_max: float, a_max: float,
                           rate: float = 1000.0) -> TimedPath:
    """The plan's own timing of its path, uniformly time-scaled to the limits (paper,
    "Executing ΣΛ trajectories with a robot"), over the lognormals' evaluated ±5σ support
    [t_a, t_b] (not the ±3σ [0, T_end], whose ends are at ~1 % of the peak speed), so it
    starts and ends at rest. The peaks are measured on each sub-movement's ln τ grid, then
    checked on the control samples themselves; positions, velocities and accelerations are
    the exact ΣΛ kinematics (no interpolation) and the jerk is the central difference of the
    exact acceleration with a half-step of ``JERK_STEP`` plan seconds."""
    s = support(plan)
    p, t_a, t_b, grid = s.plan, s.t_a, s.t_b, s.grid
    _, v_grid, a_grid = _planar(p, grid)
    peak_v, peak_a = peaks(v_grid, a_grid)
    k, limiting = time_scale(peak_v, peak_a, SAFETY * v_max, SAFETY * a_max)
    if k == 0.0:  # a dot: nothing moves, keep the plan timing
        k = 1.0
    for _ in range(5):
        t, stretch = control_samples(k * (t_b - t_a), rate)
        k_robot = k * stretch
        t_plan = np.minimum(t_a + t / k_robot, t_b)
        x, v, a = _planar(p, t_plan)
        v, a = v / k_robot, a / k_robot**2
        worst = max(peaks(v, a)[0] / v_max, math.sqrt(peaks(v, a)[1] / a_max))
        if worst <= 1.0:
            break
        k = k_robot * worst * (1.0 + 1e-6)
    else:
        raise AssertionError(f"ΣΛ time scale {k} does not converge")  # pragma: no cover
    ahead = _planar(p, t_plan + JERK_STEP)[2]
    behind = _planar(p, t_plan - JERK_STEP)[2]
    jerk = (ahead - behind) / (2.0 * JERK_STEP) / k_robot**3
    return TimedPath(t, x, v, a, jerk, "sigma-lognormal",
                     {"time_scale": k_robot, "limiting": limiting, "support": (t_a, t_b)})
