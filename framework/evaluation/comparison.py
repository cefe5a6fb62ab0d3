"""The paper's evaluation of a ΣΛ motion (section "Evaluation"): three timings of one path
of a plan under the same limits, their metrics and the ratios method/ΣΛ — the engine of
the 'evaluate' kind (:mod:`inkmotion.kinds.evaluate` reads the plan and writes the files).

Units: the plan is in canvas px; the limits are the robot's (m/s, m/s²). The canvas is put
on the setup's paper (:class:`inkmotion.robot.calibration.PaperMapping`, scale s m/px), so
the timings run in px with v_max/s and a_max/s², and every metric is reported in metres.

Ratios (> 1 means ΣΛ is better, as in the paper's table): duration T_m / T_ΣΛ (the ratio of
inverse durations ΣΛ over method), MSJ_m / MSJ_ΣΛ (lower MSJ is smoother), LDJ_m / LDJ_ΣΛ
(LDJ is negative and nearer 0 when smoother, so a less smooth method has the larger
magnitude). MSJ also at equal duration, MSJ_m·T_m⁶ / (MSJ_ΣΛ·T_ΣΛ⁶): under the same limits
a faster timing has a larger MSJ for being faster alone (MSJ ∝ T⁻⁶), which this removes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from inkmotion.errors import InputError

#: the methods, in the table's order: ΣΛ, path-constrained minimum jerk with optimised
#: passage times through the via points, the same with the ΣΛ trajectory's own passage
#: times (the variant the paper most likely used), time-optimal
METHODS = ("sigma-lognormal", "minimum-jerk", "minimum-jerk-sigma-times", "time-optimal")
#: per metric: the paper's finding for each alternative, as "ratio > 1" (ΣΛ better) or not
PAPER_DIRECTION = {
    ("minimum-jerk", "duration"): None,  # not stated by the paper
    ("minimum-jerk", "msj"): False,  # minimum jerk smoother on MSJ
    ("minimum-jerk", "ldj"): True,  # ΣΛ smoother on LDJ
    ("minimum-jerk-sigma-times", "duration"): None,
    ("minimum-jerk-sigma-times", "msj"): False,
    ("minimum-jerk-sigma-times", "ldj"): True,
    ("time-optimal", "duration"): False,  # TOTG faster
    ("time-optimal", "msj"): True,  # ΣΛ smoother on both measures
    ("time-optimal", "ldj"): True,
}


def choose_path(drawing: Any, index: int) -> int:
    """The path to evaluate: ``index``, or the longest (by sampled arc length) for −1."""
    from inkmotion.outputs.sampling import sample

    n = len(drawing.plans)
    if index >= n:
        raise InputError(f"The plan has {n} paths (0..{n - 1}); there is no path {index}.")
    if index >= 0:
        return index
    lengths = [float(np.linalg.norm(np.diff(sample(p).positions[:, :2], axis=0),
                                    axis=1).sum()) for p in drawing.plans]
    return int(np.argmax(lengths))


def total_figures(figures: list[dict[str, float]], integrals: list[float],
                  peaks: list[float]) -> dict[str, float]:
    """One method's figures over several paths, the drawing's motion seen as one with the
    pen lifts left out: duration ΣT_p, MSJ = Σ∫|j|² / ΣT, LDJ = −ln(ΣT³/v_peak²·Σ∫|j|²)
    with v_peak the highest peak speed (the definitions of :mod:`inkmotion.evaluation.
    metrics` over the concatenated motion), peak speed the highest, speed peaks the sum."""
    T = sum(f["duration"] for f in figures)
    jerk = sum(integrals)
    v_peak = max(peaks)
    return {"duration": T, "inverse_duration": 1.0 / T, "peak_speed": v_peak,
            "speed_peaks": float(sum(f["speed_peaks"] for f in figures)),
            "msj": jerk / T, "ldj": float(-np.log(T**3 / v_peak**2 * jerk))}


@dataclass(frozen=True)
class Comparison:
    """The three timings of one path and their figures (metres), see :func:`compare`."""

    timed: dict[str, Any]  # method -> TimedPath (px)
    table: dict[str, dict[str, float]]  # method -> duration, MSJ, LDJ, ...
    ratios: dict[str, dict[str, float]]  # alternative -> {duration, msj, ldj} / ΣΛ's
    holds: dict[str, bool | None]  # "method/metric" -> the paper's direction holds


def paper_scale(canvas: tuple[float, float], setup: str | None = None) -> float:
    """m per canvas px when the canvas is put on the setup's paper (default setup: None)."""
    from inkmotion.robot.calibration import PaperMapping
    from inkmotion.robot.setup import load_setup

    robot = load_setup(setup or None)
    return PaperMapping.from_canvas(canvas, robot.paper, robot.margin).scale


def compare(plan: Any, v_max: float, a_max: float, scale: float, rate: float = 1000.0,
            progress: Any = None) -> Comparison:
    """ΣΛ, path-constrained minimum jerk and time-optimal timings of ``plan``'s path under
    |v| ≤ ``v_max`` (m/s) and |a| ≤ ``a_max`` (m/s²) on paper at ``scale`` m/px, sampled
    at ``rate`` Hz; ``progress(k)`` is called after the k-th timing (k = 1..3)."""
    from inkmotion.evaluation.minjerk import minimum_jerk_timing
    from inkmotion.evaluation.time_optimal import time_optimal_timing
    from inkmotion.evaluation.timings import sigma_lognormal_timing

    v_px, a_px = v_max / scale, a_max / scale
    sigma = sigma_lognormal_timing(plan, v_px, a_px, rate)
    timings = [sigma]
    for make in (minimum_jerk_timing,
                 lambda x, v, a, r: minimum_jerk_timing(x, v, a, r, times=sigma.t),
                 time_optimal_timing):
        if progress is not None:
            progress(len(timings))
        timings.append(make(sigma.position, v_px, a_px, rate))
    if progress is not None:
        progress(len(METHODS))
    timed = dict(zip(METHODS, timings, strict=True))
    table = {name: method_figures(path, scale, rate) for name, path in timed.items()}
    return Comparison(timed, table, *ratios_and_directions(table))


def ratios_and_directions(table: dict[str, dict[str, float]]
                          ) -> tuple[dict[str, dict[str, float]], dict[str, bool | None]]:
    """The ratios method/ΣΛ of a table of figures (:func:`ratio_row`) and, per
    "method/metric", whether the paper's direction holds (None: it states none)."""
    ratios = {name: ratio_row(table[name], table[METHODS[0]]) for name in METHODS[1:]}
    holds = {f"{m}/{k}": (None if want is None else bool((ratios[m][k] > 1) == want))
             for (m, k), want in PAPER_DIRECTION.items()}
    return ratios, holds


def ratio_row(method: dict[str, float], sigma: dict[str, float]) -> dict[str, float]:
    """Ratios method/ΣΛ of duration, MSJ and LDJ, and of MSJ·T⁶ (``msj_equal_duration``:
    MSJ scales as T⁻⁶ under a uniform time scaling, so this compares the two as if both
    lasted as long: a faster timing is not penalised for being faster)."""
    out = {k: method[k] / sigma[k] for k in ("duration", "msj", "ldj")}
    out["msj_equal_duration"] = out["msj"] * out["duration"] ** 6
    return out


def over_paths(per_path: dict[int, Comparison]) -> dict[str, dict[str, float]]:
    """Each method's figures over the paths (:func:`total_figures`); one path's as they are."""
    if len(per_path) == 1:
        return next(iter(per_path.values())).table
    out = {}
    for name in METHODS:
        figures = [c.table[name] for c in per_path.values()]
        out[name] = total_figures(figures, [f["msj"] * f["duration"] for f in figures],
                                  [f["peak_speed"] for f in figures])
    return out


def method_figures(path: Any, scale: float, rate: float) -> dict[str, float]:
    """Duration, inverse duration, peak speed, speed peaks, MSJ and LDJ of a timed path, in
    metres. Every method's jerk is the one numerical derivative of its exact acceleration
    (each timing gives its velocity and acceleration in closed form): differentiated three
    times, the ΣΛ positions' last bits (its lognormals are evaluated over ±5σ, whose
    tails, 3·10⁻⁷ of a stroke, jump in at the window's end) made its MSJ up to 28 % high,
    which favoured the other methods."""
    from inkmotion.evaluation import metrics as M

    figures = dict(M.trajectory_metrics(path.position * scale, 1.0 / rate,
                                        velocity=path.velocity * scale,
                                        acceleration=path.acceleration * scale))
    figures["inverse_duration"] = 1.0 / figures["duration"]
    return {k: (float(v) if np.ndim(v) == 0 else v) for k, v in figures.items()}
