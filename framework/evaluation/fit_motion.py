"""Motion figures of a fitted drawing, for the quality benchmark and the fit's report: the
fit's speed peaks, their agreement with the recorded human motion when the input carries
time stamps (:mod:`inkmotion.evaluation.human`, the paper's Fig. 2c), and the paper's
evaluation ratios (:func:`inkmotion.evaluation.comparison.compare`, section "Evaluation") on
the drawing's longest path under the default robot limits.

Speed peaks are counted per path with :func:`inkmotion.evaluation.metrics.speed_peaks`
(prominence 5 % of that path's peak speed) on the plan sampled uniformly in time, and
summed over the paths: a sparse, human-like plan has about one peak per sub-movement, a
plan whose lognormals merge into a spline has far fewer.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: the robot limits of the evaluation ratios (the setup's defaults, m/s and m/s²)
V_MAX = 0.25
A_MAX = 2.5
#: sampling rate of the evaluation's timings in the benchmark, Hz
RATE = 500.0


def fit_speed_peaks(drawing: Any, prominence: float = 0.05) -> int:
    """Speed peaks of every path of ``drawing`` (a Drawing), summed (module docstring)."""
    from inkmotion.evaluation.metrics import speed_peaks
    from inkmotion.outputs.sampling import sample

    total = 0
    for plan in drawing.plans:
        s = sample(plan)
        dt = float(s.t[1] - s.t[0]) if len(s.t) > 1 else 1.0
        padded = np.concatenate(([0.0], s.speed, [0.0]))  # the pen at rest before and after
        total += len(speed_peaks(padded, dt, prominence=prominence))
    return total


def pinned_overlaps(plans: list[Any], tolerance: float = 1e-6) -> list[tuple[int, int, float]]:
    """The overlaps Δt_i (i ≥ 2; Δt_1 is unused) within ``tolerance`` of a clamp bound, as
    (path, sub-movement i, bound), both 1-based: where the smoothing cost pins the plan,
    which there stops being a model of movement (two sub-movements on the 0.1 floor start
    as nearly at once as the model allows: the plan has more targets than the motion has
    movements)."""
    from inkmotion.sigma_lognormal.params import DELTA_T_RANGE

    pinned = []
    for k, plan in enumerate(plans):
        for i, dt in enumerate(plan.delta_t.detach().cpu().double().tolist()[1:], start=2):
            pinned += [(k + 1, i, bound) for bound in DELTA_T_RANGE
                       if abs(dt - bound) <= tolerance]
    return pinned


def overlap_count(plans: list[Any]) -> int:
    """The overlaps Δt_i (i ≥ 2) of all the plans: m − 1 per path of m sub-movements."""
    return sum(max(0, len(plan.delta_t) - 1) for plan in plans)


def delta_t_at_clamp(plans: list[Any], tolerance: float = 1e-6) -> float:
    """Share of the overlaps Δt_i (i ≥ 2) on a clamp bound (:func:`pinned_overlaps`); 0 when
    no path has two sub-movements."""
    overlaps = overlap_count(plans)
    return len(pinned_overlaps(plans, tolerance)) / overlaps if overlaps else 0.0


def _share_on_bounds(plans: list[Any], field: str, bounds: tuple[float, ...],
                     tolerance: float) -> float:
    """Share of the plans' values of ``field`` (one per sub-movement) within ``tolerance``
    of one of ``bounds``; 0 for no sub-movement."""
    values = [v for plan in plans for v in getattr(plan, field).detach().cpu().double().tolist()]
    at = sum(1 for v in values if min(abs(v - b) for b in bounds) <= tolerance)
    return at / len(values) if values else 0.0


def delta_at_clamp(plans: list[Any], limit: float, tolerance: float = 1e-6) -> float:
    """Share of the turning angles δ_i within ``tolerance`` of their clamp ±``limit``
    (radians: the most one sub-movement's arc may turn in the fit, its ``--max-turn``):
    where the model's curvature limit binds (a tight loop or hook drawn with too few
    targets); 0 for no sub-movement."""
    return _share_on_bounds(plans, "delta", (-limit, limit), tolerance)


def ac_at_clamp(plans: list[Any], tolerance: float = 1e-6) -> float:
    """Share of the shapes Ac_i within ``tolerance`` of a bound of
    :data:`~inkmotion.sigma_lognormal.params.AC_RANGE` (1e-4, the most symmetric bell; 0.1,
    the most skewed): where the fit wanted a shape the authors' range does not hold; 0 for
    no sub-movement (and for a fit whose shapes do not learn: they stay at 0.01)."""
    from inkmotion.sigma_lognormal.params import AC_RANGE

    return _share_on_bounds(plans, "ac", tuple(AC_RANGE), tolerance)


def evaluation_ratios(drawing: Any) -> dict[str, float]:
    """The paper's ratios method/ΣΛ (> 1: ΣΛ better) of duration, MSJ and LDJ for minimum
    jerk and time-optimal timing of the longest path, at :data:`V_MAX`, :data:`A_MAX`."""
    from inkmotion.evaluation.comparison import choose_path, compare, paper_scale

    plan = drawing.plans[choose_path(drawing, -1)]
    c = compare(plan, V_MAX, A_MAX, paper_scale(drawing.canvas), RATE)
    short = {"minimum-jerk": "minjerk", "minimum-jerk-sigma-times": "minjerk_sigma",
             "time-optimal": "totg"}
    return {f"{short[m]}_{k}": v for m, r in c.ratios.items() for k, v in r.items()}


def recorded_columns(human: dict[str, Any]) -> dict[str, Any]:
    """The benchmark's columns of a recorded agreement
    (:func:`inkmotion.kinds.evaluate.recorded_agreement`)."""
    return {"recorded_peaks": human["recorded_peaks"], "matched_peaks": human["matched_peaks"],
            "matched_by_chance": human.get("matched_by_chance"),
            "peaks_f1": human.get("peaks_f1"),
            "recorded_duration_s": human["recorded_duration_s"],
            "peak_offset": human["mean_position_offset"]}


def report_figures(report: dict[str, Any]) -> dict[str, Any]:
    """The same figures as :func:`item_figures` (without the ratios) read from a fit's
    report.json, which already holds them: nothing is sampled or read again."""
    out: dict[str, Any] = {"fit_speed_peaks": report["speed_peaks"]}
    if report.get("recorded") is not None:
        out.update(recorded_columns(report["recorded"]))
    return out


def item_figures(item_dir: Path, human: dict[str, Any] | None, *, ratios: bool = True
                 ) -> dict[str, Any]:
    """The motion figures of the fit in ``item_dir`` (its plan.json): ``fit_speed_peaks``;
    with ``human`` (the recording's agreement, :func:`inkmotion.kinds.evaluate.
    recorded_agreement`, None without time stamps) ``recorded_peaks``, ``matched_peaks``,
    ``recorded_duration_s``, ``peak_offset`` (normalised arc length); with ``ratios`` the
    evaluation ratios (``minjerk_duration``, ..., ``totg_ldj``)."""
    from inkmotion.sigma_lognormal import Drawing

    drawing = Drawing.load(Path(item_dir) / "plan.json")
    out: dict[str, Any] = {"fit_speed_peaks": fit_speed_peaks(drawing)}
    if human is not None:
        out.update(recorded_columns(human))
    if ratios:
        out.update(evaluation_ratios(drawing))
    return out
