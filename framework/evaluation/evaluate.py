"""The 'evaluate' job kind's work (paper, section "Evaluation"): three timings of one path
of a plan under the same limits, their metrics, the ratios method/ΣΛ, and the plots.

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

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from inkmotion.errors import InputError
from inkmotion.events import StepState

if TYPE_CHECKING:
    from inkmotion.jobs.shell import Job

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


def run_evaluate(job: Job) -> dict[str, Any]:
    """Time, measure, compare and plot the job's plan: every path (``--path -1``: the
    figures per path and over the whole drawing, :func:`total_figures`) or one path."""
    from inkmotion.evaluation import metrics as M
    from inkmotion.sigma_lognormal import Drawing

    p = job.params
    drawing = Drawing.load(job.spec.inputs["plan"])
    scale = paper_scale(drawing.canvas, p.setup)
    indices = list(range(len(drawing.plans))) if p.path < 0 else [choose_path(drawing, p.path)]
    shown = choose_path(drawing, p.path)  # the longest, or the one asked for: the plots
    job.start((int(drawing.canvas[0]), int(drawing.canvas[1])))
    n = len(METHODS)
    per_path: dict[int, Comparison] = {}
    for j, index in enumerate(indices):
        per_path[index] = compare(
            drawing.plans[index], p.v_max, p.a_max, scale, p.rate,
            progress=lambda k, j=j: job.observers.on_step(
                StepState(j * n + k, n * len(indices), {}, 0.0)))
    table = _over_paths(per_path)
    ratios, holds = ratios_and_directions(table)
    sigma = per_path[shown].timed[METHODS[0]]
    minima = M.speed_minima_at_curvature_maxima(sigma.position * scale, 1.0 / p.rate)
    doc = {"path": "all" if p.path < 0 else shown, "moves": sum(drawing.plans[i].m
                                                                for i in indices),
           "v_max": p.v_max, "a_max": p.a_max, "m_per_px": scale, "methods": table,
           "ratios": ratios, "paper_direction_holds": holds,
           "paths": [{"path": i, "moves": drawing.plans[i].m, "methods": c.table,
                      "ratios": c.ratios, "paper_direction_holds": c.holds}
                     for i, c in per_path.items()],
           "plotted_path": shown, "speed_minima_at_curvature_maxima": minima,
           "method_notes": {"time-optimal": "TOPP-RA (toppra), standing in for TOTG",
                            "minimum-jerk": "passage times through the via points optimised",
                            "minimum-jerk-sigma-times": "the ΣΛ trajectory's own passage "
                            "times through the same via points"}}
    if p.recording:
        doc["human"] = human_figures(p.recording, drawing, job.folder)
    (job.folder / "evaluation.json").write_text(json.dumps(doc, indent=1, default=float))
    write_csv(job.folder / "evaluation.csv", table, ratios,
              per_path if len(per_path) > 1 else None)
    from inkmotion.evaluation.plots import plot_minima, plot_speeds

    plot_speeds(job.folder / "speeds.png", per_path[shown].timed, scale)
    plot_minima(job.folder / "minima.png", sigma.position, 1.0 / p.rate, drawing.canvas)
    print_table(table, ratios, f"evaluation, {len(indices)} path(s)")
    metrics = {f"{m}_{k}_ratio": v for m, r in ratios.items() for k, v in r.items()}
    return {**doc, "metrics": metrics}


def _over_paths(per_path: dict[int, Comparison]) -> dict[str, dict[str, float]]:
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
    metres."""
    from inkmotion.evaluation import metrics as M

    figures = dict(M.trajectory_metrics(path.position * scale, 1.0 / rate))
    figures["inverse_duration"] = 1.0 / figures["duration"]
    return {k: (float(v) if np.ndim(v) == 0 else v) for k, v in figures.items()}


def human_figures(recording: str, drawing: Any, folder: Path) -> dict[str, Any]:
    """Agreement of the fit's speed peaks with the recorded motion's (when it has times)."""
    from inkmotion.evaluation.human import human_agreement_from_files

    return human_agreement_from_files(recording, drawing, folder / "human_speeds.png")


def write_csv(path: Path, table: dict, ratios: dict,
              per_path: dict[int, Comparison] | None = None) -> None:
    """evaluation.csv: one row per method (duration, MSJ, LDJ, ..., MSJ·T⁶ in the
    msj_equal_duration column) and the ratio rows, over the drawing; with ``per_path``
    the same rows of each path after them, named ``path N: ...``."""
    keys = ["duration", "inverse_duration", "peak_speed", "speed_peaks", "msj", "ldj",
            "msj_equal_duration"]
    lines = ["row," + ",".join(keys)]

    def rows(prefix: str, table: dict, ratios: dict) -> None:
        for name, figures in table.items():
            row = {**figures, "msj_equal_duration": figures["msj"] * figures["duration"] ** 6}
            lines.append(prefix + name + "," + ",".join(f"{row[k]:.6g}" for k in keys))
        for name, r in ratios.items():
            row = {"duration": r["duration"], "inverse_duration": 1.0 / r["duration"],
                   "msj": r["msj"], "ldj": r["ldj"],
                   "msj_equal_duration": r["msj_equal_duration"]}
            lines.append(f"{prefix}{name}/sigma-lognormal," + ",".join(
                f"{row[k]:.6g}" if k in row else "" for k in keys))

    rows("", table, ratios)
    for index, c in (per_path or {}).items():
        rows(f"path {index}: ", c.table, c.ratios)
    path.write_text("\n".join(lines) + "\n")


def print_table(table: dict, ratios: dict, title: str = "evaluation") -> None:
    """The table on the terminal (rich)."""
    from rich.console import Console
    from rich.table import Table

    t = Table("", "duration s", "1/duration", "MSJ m²/s⁶", "LDJ", "MSJ·T⁶", title=title)
    for name, f in table.items():
        t.add_row(name, f"{f['duration']:.3f}", f"{f['inverse_duration']:.4f}",
                  f"{f['msj']:.4g}", f"{f['ldj']:.3f}", f"{f['msj'] * f['duration'] ** 6:.4g}")
    for name, r in ratios.items():
        t.add_row(f"{name}/ΣΛ (>1: ΣΛ better)", f"{r['duration']:.3f}",
                  f"{1.0 / r['duration']:.3f}", f"{r['msj']:.3f}", f"{r['ldj']:.3f}",
                  f"{r['msj_equal_duration']:.3f}")
    Console(stderr=True).print(t)
