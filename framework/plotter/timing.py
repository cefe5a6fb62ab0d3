"""Timing a drawing for a pen plotter: one uniform time scale, then short G1 segments at a
fixed time step whose feeds follow the ΣΛ speed.

Scale. As for the robot (:mod:`inkmotion.robot.timing`), t_machine = k·t_plan divides the
speed by k and the acceleration by k², and one k serves the whole drawing so that the
gesture keeps its rhythm. Three limits set it:

    k ≥ max|v| / v_max,   k ≥ sqrt(max|a| / a_max),   k ≥ sqrt(max a_n / A_j),

the third being the firmware's corner rule. A planner with junction deviation δ (GRBL
planner.c; Marlin and Klipper use the same rule) passes the junction of two segments that
turn by φ at most at v_j² = a·δ·c/(1 − c), c = cos(φ/2). Segments of one time step Δt along
a curve of curvature κ turn by φ ≈ κ·v·Δt, so v_j ≈ sqrt(8aδ)/(κ v Δt), and v_j ≥ v holds
while the normal acceleration a_n = κ v² stays below A_j = sqrt(8·a·δ)/Δt: a curve drawn
faster than that would be slowed at every junction and lose its ΣΛ profile. Some planners
(and the gcode-simulator package) round a corner by the circle through it instead,
r = δ / sin(φ/2), v_j² = a·r ≈ 2aδ/φ, which asks for κ v³ = |v × a| ≤ 2aδ/Δt (k³ scaling):
``junctions="strict"`` (the default) keeps both rules, ``"grbl"`` only GRBL's, which is
faster on GRBL firmware but leaves other planners to slow the curves. The peaks are
measured on the plan's ln τ grid (:mod:`inkmotion.sigma_lognormal.support`) at ``SAFETY``
of the limits, then every junction of the actual segments is checked with the exact rule
against the plan's own speed at that instant (a cusp, where the ΣΛ speed dips, may be
sharp) and k is raised until all pass.

Segments. Each stroke is sampled at t_plan = t_a + j·Δt/k over its support; the creeping
ends (the pen within ``TRIM_MM`` of where it starts or stops: the lognormals' tails) are
dropped, and consecutive samples closer than ``MIN_SEGMENT_MM`` are merged, so no block is
shorter than a motor step. A segment's feed is its length over its duration (its mean
speed): the machine spends the plan's time on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from inkmotion.plotter.resolution import on_grid, written_feed
from inkmotion.robot.calibration import PaperMapping
from inkmotion.sigma_lognormal.kinematics import kinematics
from inkmotion.sigma_lognormal.plan import Drawing
from inkmotion.sigma_lognormal.support import Support, support

#: fraction of each limit the measured peaks are scaled to
SAFETY = 0.98
#: mm: the pen's creep at a stroke's ends below this is not drawn
TRIM_MM = 0.02
#: mm: the shortest segment (samples closer than this are merged)
MIN_SEGMENT_MM = 0.05
#: s: the default time step of the G1 segments
DEFAULT_STEP_S = 0.01
#: degrees: junctions turning less than this are kept at the plan's speed (the time scale
#: makes room for them); sharper ones are the plan's cusps, where its speed dips anyway,
#: and the machine may slow there (the time estimate counts it)
SMOOTH_TURN_DEG = 20.0


@dataclass(frozen=True)
class PlotStroke:
    """One stroke on paper: ``points`` (n + 1, 2) mm, ``durations`` (n,) s per segment,
    ``plan_speed`` (n,) mm/s the ΣΛ speed at each segment's middle (time-scaled), the plan
    path it comes from and its pen."""

    path: int
    pen: int
    points: np.ndarray
    durations: np.ndarray
    plan_speed: np.ndarray

    @property
    def lengths(self) -> np.ndarray:
        return np.linalg.norm(np.diff(self.points, axis=0), axis=1)

    @property
    def feeds(self) -> np.ndarray:
        """mm/s per segment: length / duration."""
        return self.lengths / self.durations


@dataclass(frozen=True)
class PlotTiming:
    """The strokes in drawing order, the time scale and which limit set it."""

    strokes: list[PlotStroke]
    time_scale: float
    limiting: str
    info: dict


def circle_junction_speed(u1: np.ndarray, u2: np.ndarray, accel: float, deviation: float
                          ) -> np.ndarray:
    """The stricter corner rule: v_j² = a·δ / sin(φ/2) (the circle through the corner)."""
    cos_phi = np.clip(np.sum(u1 * u2, axis=1), -1.0, 1.0)
    sin_half = np.sqrt(np.maximum(0.5 * (1.0 - cos_phi), 0.0))
    with np.errstate(divide="ignore"):
        return np.where(sin_half < 1e-12, np.inf, np.sqrt(accel * deviation / sin_half))


def junction_speed(u1: np.ndarray, u2: np.ndarray, accel: float, deviation: float
                   ) -> np.ndarray:
    """GRBL's junction speed (mm/s) between unit directions ``u1`` and ``u2`` (n, 2):
    v_j² = a·δ·c/(1 − c), c = cos(φ/2) = sqrt((1 + u1·u2)/2); infinite when straight."""
    cos_phi = np.clip(np.sum(u1 * u2, axis=1), -1.0, 1.0)
    c = np.sqrt(0.5 * (1.0 + cos_phi))
    with np.errstate(divide="ignore"):
        return np.where(c > 1.0 - 1e-12, np.inf, np.sqrt(accel * deviation * c / (1.0 - c)))


def _kinematics_mm(s: Support, t: np.ndarray, mapping: PaperMapping
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    with torch.no_grad():
        x, v, a = (k[:, :2].numpy() for k in kinematics(s.plan, torch.as_tensor(t)))
    return (mapping.px_to_plane(x), mapping.velocity_to_plane(v),
            mapping.velocity_to_plane(a))


def _segments(s: Support, k: float, step: float, mapping: PaperMapping
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Points (n + 1, 2) mm, durations (n,) s, plan speeds (n,) mm/s at the segments'
    middles and (n + 1,) at their ends, of one stroke."""
    n = max(1, math.ceil(k * (s.t_b - s.t_a) / step - 1e-9))
    t = np.minimum(s.t_a + np.arange(n + 1) * step / k, s.t_b)
    p, v, _ = _kinematics_mm(s, t, mapping)
    moved_from_start = np.linalg.norm(p - p[0], axis=1) >= TRIM_MM
    moved_to_end = np.linalg.norm(p - p[-1], axis=1) >= TRIM_MM
    if not moved_from_start.any():  # a dot
        return p[:1], np.zeros(0), np.zeros(0), np.zeros(1)
    first = max(0, int(np.argmax(moved_from_start)) - 1)
    last = min(n, len(p) - int(np.argmax(moved_to_end[::-1])))
    keep = [first]
    for j in range(first + 1, last + 1):
        if np.linalg.norm(p[j] - p[keep[-1]]) >= MIN_SEGMENT_MM:
            keep.append(j)
    if keep[-1] != last:
        if len(keep) > 1:
            keep[-1] = last
        else:
            keep.append(last)
    keep_a = np.asarray(keep)
    times = t[keep_a] * k  # machine s
    mid = 0.5 * (t[keep_a[:-1]] + t[keep_a[1:]])
    _, v_mid, _ = _kinematics_mm(s, mid, mapping)
    # as the G-code says them (.resolution): each segment lasts its length at its written feed
    points = on_grid(p[keep_a])
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    feeds = np.array([written_feed(f) for f in lengths / np.diff(times)])
    return (points, lengths / feeds, np.linalg.norm(v_mid, axis=1) / k,
            np.linalg.norm(v[keep_a], axis=1) / k)


def time_for_plotter(drawing: Drawing, mapping: PaperMapping, pens: list[int], *,
                     v_max: float, a_max: float, accel: float, deviation: float,
                     step: float = DEFAULT_STEP_S, junctions: str = "strict") -> PlotTiming:
    """The strokes of ``drawing`` on paper (``mapping``: canvas px → mm), timed so that the
    feed stays ≤ ``v_max`` (mm/s), the acceleration ≤ ``a_max`` (mm/s²) and every junction
    within the machine's corner rule (its ``accel`` and junction ``deviation``); see the
    module docstring."""
    supports = [support(plan) for plan in drawing.plans]
    peak_v = peak_a = peak_n = peak_cross = 0.0
    for s in supports:
        _, v, a = _kinematics_mm(s, s.grid, mapping)
        speed = np.linalg.norm(v, axis=1)
        cross = np.abs(v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0])  # |v × a| = κ v³
        normal = cross / np.maximum(speed, 1e-12)
        peak_cross = max(peak_cross, float(cross.max()))
        peak_v = max(peak_v, float(speed.max()))
        peak_a = max(peak_a, float(np.linalg.norm(a, axis=1).max()))
        peak_n = max(peak_n, float(normal.max()))
    corner = math.sqrt(8.0 * accel * deviation) / step
    bounds = {"speed": peak_v / (SAFETY * v_max),
              "acceleration": math.sqrt(peak_a / (SAFETY * a_max)),
              "junction": math.sqrt(peak_n / (SAFETY * corner))}
    if junctions == "strict":
        circle = 2.0 * accel * deviation / step
        bounds["junction"] = max(bounds["junction"], (peak_cross / (SAFETY * circle)) ** (1 / 3))
    limiting = max(bounds, key=bounds.__getitem__)
    k = bounds[limiting]
    if k == 0.0:
        k, limiting = 1.0, "none"
    for _ in range(10):
        built = [_segments(s, k, step, mapping) for s in supports]
        worst = max([_junction_excess(p, at, accel, deviation, junctions)
                     for p, _, _, at in built]
                    + [1.0])
        if worst <= 1.0:
            break
        k *= worst * 1.01
        limiting = "junction"
    strokes = [PlotStroke(i, pens[i], p, d, v) for i, (p, d, v, _) in enumerate(built)]
    feeds = np.concatenate([st.feeds for st in strokes] + [np.zeros(1)])
    info = {"time_scale": k, "limiting": limiting, "bounds": bounds, "step_s": step,
            "junctions": junctions,
            "peak_feed": float(feeds.max()), "corner_acceleration": corner,
            "peak_normal_acceleration": peak_n / k**2,
            "peak_acceleration": peak_a / k**2, "peak_speed": peak_v / k,
            "segments": int(sum(len(st.durations) for st in strokes)),
            "junctions_within_rule": bool(worst <= 1.0),
            "sharp_junctions": int(sum(sharp_junctions(st.points) for st in strokes))}
    return PlotTiming(strokes, k, limiting, info)


def _directions(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The unit directions before and after every interior junction of a polyline (n, 2)
    each, and whether each junction is smooth (turns by less than ``SMOOTH_TURN_DEG``)."""
    d = np.diff(points, axis=0)
    u = d / np.linalg.norm(d, axis=1)[:, None]
    smooth = np.sum(u[:-1] * u[1:], axis=1) > math.cos(math.radians(SMOOTH_TURN_DEG))
    return u[:-1], u[1:], smooth


def _junction_excess(points: np.ndarray, speed_at: np.ndarray, accel: float,
                     deviation: float, junctions: str) -> float:
    """max over a stroke's smooth junctions of the plan's speed there over the machine's
    junction speed v_j (≤ 1: the machine passes them as fast as the plan does)."""
    if len(points) < 3:
        return 0.0
    u1, u2, smooth = _directions(points)
    if not smooth.any():
        return 0.0
    u1, u2 = u1[smooth], u2[smooth]
    vj = junction_speed(u1, u2, accel, deviation)
    if junctions == "strict":
        vj = np.minimum(vj, circle_junction_speed(u1, u2, accel, deviation))
    return float(np.max(speed_at[1:-1][smooth] / vj))


def sharp_junctions(points: np.ndarray) -> int:
    """How many of a stroke's junctions turn by ``SMOOTH_TURN_DEG`` or more (cusps)."""
    return 0 if len(points) < 3 else int(np.sum(~_directions(points)[2]))
