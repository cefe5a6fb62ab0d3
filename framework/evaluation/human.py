"""Agreement of a fitted ΣΛ motion with the recorded human motion of the same tag (the
paper's Fig. 2c: the fit is never shown the recorded speed, yet the minimum-time cost
"produces a similar number and location of peaks").

Recorded times. GML points may carry time stamps; the GML reader keeps them per stroke in
``Traces.meta["t"]`` (aligned with the points, which it de-duplicates together with their
times). :meth:`Traces.fit_to_canvas` scales the points uniformly and leaves the times as
they are, so the two stay aligned. GML writers use seconds or milliseconds, and the file
does not say which (a reader may: ``Traces.meta["time_unit"]``, e.g. the GML reader's
``time_unit`` option). The step between successive time stamps tells them apart where a
stroke's duration cannot (a 68-ms dash in ms and a 2-minute spiral in s): a digitiser
samples at 2 Hz to 2 kHz, so its median step is under :data:`MS_STEP` in seconds and at
least that in milliseconds.

Time quantisation. Recorders often stamp several consecutive points with the same time
(the 000000book tags: 2–3 points per ~16 ms display frame). Each distinct time is taken as
the moment the pen reached the *last* point stamped with it (the first stamp: the first
point); later points whose time does not increase are kept for the geometry but not as
time anchors. Arc length s(t) is interpolated linearly between anchors on a uniform time
grid (``rate`` Hz) and its derivative, the speed, smoothed by a Gaussian of ``smooth_s``
seconds (the "Gaussian smoothed" profile of Fig. 2c).

Peak matching. Speed peaks (:func:`inkmotion.evaluation.metrics.speed_peaks`, each stroke
taken to start and end at rest, so a peak may sit at an end) are located by
their position along the trace, the arc length normalised to [0, 1] per stroke, so the
recording and the fit compare although they run on different clocks. Peaks are paired one to
one by minimum total distance (Hungarian assignment); a pair counts as matched when the two
lie within ``tolerance`` of each other. The offset is the mean |Δs| of the matched pairs, in
that normalised arc length.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.optimize import linear_sum_assignment

from inkmotion.errors import InputError
from inkmotion.evaluation.metrics import speed_peaks

if TYPE_CHECKING:
    from inkmotion.geometry.traces import Traces

#: a recording whose median step between successive time stamps is at least this (in its
#: own unit) is in ms: a sampling rate of 2 kHz in ms, of 2 Hz in s (module docstring)
MS_STEP = 0.5
#: a recording with no step (a stroke per time stamp) whose longest stroke lasts more
#: than this (in its own unit) is in ms
MS_THRESHOLD = 100.0
#: default matching tolerance, in normalised arc length
TOLERANCE = 0.1


def _forward_steps(times: list[np.ndarray]) -> np.ndarray:
    """Every step forward between successive time stamps of the strokes ``times``."""
    steps = np.concatenate([np.diff(t) for t in times if len(t) > 1] or [np.zeros(0)])
    return steps[steps > 0]


def time_unit(times: list[np.ndarray]) -> str:
    """The unit of ``times`` (one array per stroke): "ms" when the median step between
    successive distinct time stamps is at least :data:`MS_STEP`, else "s" (module
    docstring); with no such step, "ms" when the longest stroke lasts more than
    :data:`MS_THRESHOLD`."""
    arrays = [np.asarray(t, dtype=np.float64) for t in times]
    steps = _forward_steps(arrays)
    if len(steps):
        return "ms" if float(np.median(steps)) >= MS_STEP else "s"
    longest = max((float(np.nanmax(t) - np.nanmin(t)) for t in arrays if len(t)), default=0.0)
    return "ms" if longest > MS_THRESHOLD else "s"


def times_in_seconds(times: list[np.ndarray], unit: str = "auto"
                     ) -> tuple[list[np.ndarray], str]:
    """``times`` (one array per stroke) in seconds, and their unit: ``unit`` ("s" or
    "ms"), or for "auto" the one :func:`time_unit` finds."""
    if unit == "auto":
        unit = time_unit(times)
    scale = 1000.0 if unit == "ms" else 1.0
    return [np.asarray(t, dtype=np.float64) / scale for t in times], unit


#: a recording whose strokes hold fewer distinct time stamps than this (the median) has
#: no speed peaks to compare: a bell needs a few samples, a stroke holds several bells
#: (the EyeWriter tags of the development set: 3 to 6; the paper's 49867: 34)
SPARSE_STAMPS = 8

#: a stroke whose time stamps step back by more than this many times the recording's median
#: step has a clock that jumped, not the jitter of a quantised one
JUMP_STEPS = 3.0


#: a stroke whose time stamps span more than this (s) is no pen stroke: a stamp of
#: another clock or a corrupted one (a span of 10^12 s asked for petabytes of samples)
MAX_STROKE_S = 3600.0


def _plausible_span(t: np.ndarray) -> bool:
    """Whether a stroke's times ``t`` (s) are finite and span at most
    :data:`MAX_STROKE_S`."""
    t = np.asarray(t, dtype=np.float64)
    return bool(np.isfinite(t).all()) and float(t.max() - t.min()) <= MAX_STROKE_S


def clock_jumps(times: list[np.ndarray]) -> dict[int, float]:
    """The strokes whose time stamps (in s, one array per stroke) step back by more than
    :data:`JUMP_STEPS` × the recording's median forward step, and each one's largest step
    back, s: their recorded speed would show a false plateau where the clock ran back."""
    forward = _forward_steps(times)
    if not len(forward):
        return {}
    limit = JUMP_STEPS * float(np.median(forward))
    jumps = {}
    for i, t in enumerate(times):
        back = -float(np.diff(t).min()) if len(t) > 1 else 0.0
        if back > limit:
            jumps[i] = back
    return jumps


def _strokes(indices: list[int]) -> str:
    """"stroke 3", "strokes 1, 4 and 7" (1-based), at most five named."""
    names = [str(i + 1) for i in indices[:5]] + (["…"] if len(indices) > 5 else [])
    if len(names) == 1:
        return f"stroke {names[0]}"
    return "strokes " + ", ".join(names[:-1]) + " and " + names[-1]


def arc_length(points: np.ndarray) -> np.ndarray:
    """(k,) cumulative planar arc length of the polyline ``points`` (k, D), from 0."""
    steps = np.linalg.norm(np.diff(np.asarray(points, dtype=np.float64)[:, :2], axis=0), axis=1)
    return np.concatenate(([0.0], np.cumsum(steps)))


def _new_stamps(t: np.ndarray) -> np.ndarray:
    """(k,) bool: the points of times ``t`` (k,) stamped later than every point before
    them (the first point always)."""
    new = np.ones(len(t), dtype=bool)
    new[1:] = t[1:] > np.maximum.accumulate(t)[:-1]
    return new


def time_anchors(arc: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Strictly increasing times and the arc length reached at each (module docstring):
    each new time is anchored at the last point stamped with it (the first at arc 0)."""
    t = np.asarray(t, dtype=np.float64)
    starts = np.flatnonzero(_new_stamps(t))
    ends = np.append(starts[1:] - 1, len(t) - 1)  # last point of each stamp's group
    s = arc[ends].copy()
    s[0] = arc[0]
    return t[starts], s


def advances(t: np.ndarray) -> bool:
    """Whether the times ``t`` (k,) of a stroke reach at least two distinct stamps in
    order (:func:`time_anchors`): a stroke stamped all at one time, or backwards, has no
    recorded speed."""
    return int(_new_stamps(np.asarray(t, dtype=np.float64)).sum()) >= 2


def recorded_speed(stroke: np.ndarray, t: np.ndarray, *, rate: float = 200.0,
                   smooth_s: float = 0.03,
                   unit: str = "auto") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Speed profile of one recorded stroke ``stroke`` (k, 2|3) with times ``t`` (k,).

    ``unit`` is "s", "ms" or "auto" (:func:`time_unit` of this stroke). Returns, on a
    uniform grid of ``rate`` Hz from the first to the last time: the arc length (n,) in
    the stroke's units, the speed (n,) in units/s, smoothed by a Gaussian of ``smooth_s``
    s, and the times (n,) in s."""
    t = np.asarray(t, dtype=np.float64)
    if len(t) != len(stroke):
        raise ValueError(f"{len(stroke)} points but {len(t)} times")
    if unit == "ms" or (unit == "auto" and time_unit([t]) == "ms"):
        t = t / 1000.0
    if not _plausible_span(t):
        raise ValueError(f"the stroke's times are not finite or span over {MAX_STROKE_S:g} s")
    anchor_t, anchor_s = time_anchors(arc_length(stroke), t)
    if len(anchor_t) < 2:
        raise ValueError("the stroke has fewer than two distinct times")
    n = max(int(np.floor((anchor_t[-1] - anchor_t[0]) * rate)) + 1, 2)
    times = anchor_t[0] + np.arange(n) / rate
    arc = np.interp(times, anchor_t, anchor_s)
    speed = np.gradient(arc, 1.0 / rate) if n > 2 else np.full(n, (arc[1] - arc[0]) * rate)
    if smooth_s > 0:
        speed = gaussian_filter1d(speed, smooth_s * rate, mode="nearest")
    return arc, speed, times


def _normalised(arc: np.ndarray) -> np.ndarray:
    arc = np.asarray(arc, dtype=np.float64)
    span = float(arc[-1] - arc[0])
    return (arc - arc[0]) / span if span > 0 else np.zeros_like(arc)


def _peaks_from_rest(speed: np.ndarray, prominence: float) -> np.ndarray:
    """Speed peak indices with the stroke taken to start and end at rest (a zero speed is
    put before and after it), so a short flick whose speed only rises and falls at the ends
    of the recording still has its one peak."""
    padded = np.concatenate(([0.0], np.asarray(speed, dtype=np.float64), [0.0]))
    return np.clip(speed_peaks(padded, 1.0, prominence=prominence) - 1, 0, len(speed) - 1)


def compare_peaks(recorded_arc: np.ndarray, recorded_speed: np.ndarray, fit_arc: np.ndarray,
                  fit_speed: np.ndarray, tolerance: float = TOLERANCE, *,
                  prominence: float = 0.05) -> dict[str, Any]:
    """Speed peaks of a recorded and a fitted stroke located along the trace (arc length
    normalised to [0, 1]) and paired (module docstring). Both speed arrays are taken as
    uniform in time, already smoothed as wanted.

    Returns recorded_peaks, fit_peaks (counts), matched (pairs within ``tolerance``),
    by_chance (:func:`matched_by_chance`), mean_offset (mean |Δs| of the matched pairs,
    normalised arc length; None when none), and the peak positions recorded_at, fit_at."""
    rec_at = _normalised(recorded_arc)[_peaks_from_rest(recorded_speed, prominence)]
    fit_at = _normalised(fit_arc)[_peaks_from_rest(fit_speed, prominence)]
    offsets = _matched_offsets(rec_at, fit_at, tolerance)
    return {
        "recorded_peaks": int(len(rec_at)),
        "fit_peaks": int(len(fit_at)),
        "matched": int(len(offsets)),
        "by_chance": matched_by_chance(rec_at, len(fit_at), tolerance),
        "mean_offset": float(offsets.mean()) if len(offsets) else None,
        "recorded_at": rec_at.tolist(),
        "fit_at": fit_at.tolist(),
    }


#: random placements averaged by :func:`matched_by_chance`
CHANCE_DRAWS = 64


def _matched_offsets(rec_at: np.ndarray, fit_at: np.ndarray, tolerance: float) -> np.ndarray:
    """|Δs| of the pairs of the one-to-one assignment of least total distance between the
    peak positions ``rec_at`` and ``fit_at`` that lie within ``tolerance``."""
    if not len(rec_at) or not len(fit_at):
        return np.zeros(0)
    cost = np.abs(rec_at[:, None] - fit_at[None, :])
    rows, cols = linear_sum_assignment(cost)
    offsets = cost[rows, cols]
    return offsets[offsets <= tolerance]


def matched_by_chance(rec_at: np.ndarray, fit_peaks: int, tolerance: float) -> float:
    """The matches ``fit_peaks`` peaks placed at random along the stroke (uniform in
    normalised arc length) get on average against the recorded ones at ``rec_at``: the
    level a fit's ``matched`` must beat to say anything (a fixed seed: the same figure
    every time)."""
    if not len(rec_at) or not fit_peaks:
        return 0.0
    rng = np.random.default_rng(0)
    rec_at = np.asarray(rec_at, dtype=np.float64)
    return float(np.mean([len(_matched_offsets(rec_at, rng.uniform(0.0, 1.0, fit_peaks),
                                               tolerance)) for _ in range(CHANCE_DRAWS)]))


def human_agreement(recorded: list[tuple[np.ndarray, np.ndarray]],
                    fit: list[tuple[np.ndarray, np.ndarray]], *,
                    tolerance: float = TOLERANCE, rate: float = 200.0, smooth_s: float = 0.03,
                    prominence: float = 0.05) -> dict[str, Any]:
    """Peak agreement stroke by stroke.

    ``recorded``: per stroke (points (k, 2|3), times (k,) in s); ``fit``: per stroke
    (positions (n, D) uniform in time, speeds (n,)), in the same canvas coordinates and the
    same order. Returns {"strokes": [...], "total": {...}} with recorded_duration_s,
    recorded_peaks, fit_peaks, matched_peaks, matched_by_chance (as many fit peaks placed
    at random), mean_position_offset (normalised arc length; the total weighs strokes by
    their matched peaks) and in the total peaks_f1, 2·matched / (recorded + fit peaks): a
    fit with more peaks than the hand's scores lower."""
    if len(recorded) != len(fit):
        raise ValueError(f"{len(recorded)} recorded strokes but {len(fit)} fitted ones")
    strokes = []
    for (points, t), (positions, speeds) in zip(recorded, fit, strict=True):
        arc, speed, times = recorded_speed(points, t, rate=rate, smooth_s=smooth_s, unit="s")
        c = compare_peaks(arc, speed, arc_length(positions), speeds, tolerance,
                          prominence=prominence)
        strokes.append({"recorded_duration_s": float(times[-1] - times[0]),
                        "recorded_peaks": c["recorded_peaks"], "fit_peaks": c["fit_peaks"],
                        "matched_peaks": c["matched"], "matched_by_chance": c["by_chance"],
                        "mean_position_offset": c["mean_offset"]})
    matched = sum(s["matched_peaks"] for s in strokes)
    offset = (sum(s["mean_position_offset"] * s["matched_peaks"] for s in strokes
                  if s["matched_peaks"]) / matched) if matched else None
    recorded_peaks = sum(s["recorded_peaks"] for s in strokes)
    fit_peaks = sum(s["fit_peaks"] for s in strokes)
    both = recorded_peaks + fit_peaks
    total = {"recorded_duration_s": sum(s["recorded_duration_s"] for s in strokes),
             "recorded_peaks": recorded_peaks, "fit_peaks": fit_peaks,
             "matched_peaks": matched,
             "matched_by_chance": round(sum(s["matched_by_chance"] for s in strokes), 2),
             "peaks_f1": 2 * matched / both if both else None,
             "mean_position_offset": offset}
    return {"strokes": strokes, "total": total, "tolerance": tolerance, "smooth_s": smooth_s}


#: human_speeds.png's width × height, px, and its curves' colours
PROFILES_SIZE = (1080, 384)
RECORDED_RGB = (153, 153, 153)
FIT_RGB = (34, 34, 34)


def plot_speed_profiles(path: str | Path, recorded: list[tuple[np.ndarray, np.ndarray]],
                        fit: list[tuple[np.ndarray, np.ndarray]]) -> None:
    """PNG of both speed profiles along the trace: per stroke (arc length (n,), speed (n,)).

    x: position along the whole drawing, strokes concatenated; stroke i spans its share of
    the recorded total arc length, and both profiles are placed on it by their own arc
    length normalised to [0, 1], so the axis runs from 0 to 1. y: each stroke's speed
    divided by that stroke's own peak speed (the two run on different clocks)."""
    from inkmotion.outputs.chart import BOLD, THIN, Chart

    lengths = np.array([float(a[-1] - a[0]) for a, _ in recorded])
    total = float(lengths.sum()) or 1.0
    starts = np.concatenate(([0.0], np.cumsum(lengths)))[:-1] / total
    chart = Chart(PROFILES_SIZE, 1.0, 1.1, y_ticks_to=1.0,
                  x_label="position along the drawing (arc length, strokes concatenated, 0..1)",
                  y_label="speed / stroke's peak")
    for start in starts[1:]:
        chart.rule(float(start), (221, 221, 221), THIN)
    assert len(recorded) == len(fit), (len(recorded), len(fit))
    for profiles, rgb, label in ((recorded, RECORDED_RGB, "recorded (smoothed)"),
                                 (fit, FIT_RGB, "sigma-lognormal fit")):
        chart.lines([(starts[i] + lengths[i] / total * _normalised(arc),
                      speed / max(float(np.max(speed)), 1e-12))
                     for i, (arc, speed) in enumerate(profiles)], rgb, BOLD, label)
    chart.write(path)


#: mean distance from a recording to a plan's motion, as a share of the canvas's longer
#: side, past which the recording is not the drawing the plan was fitted to (15 px on a
#: 350-px canvas; a fit's mean goal is 0.6 px there)
APART_SHARE = 15.0 / 350.0


def _apart(recorded: list[np.ndarray], fitted: list[np.ndarray]) -> float:
    """Mean Chamfer distance between the recording and the motion, px on the canvas."""
    from inkmotion.geometry.chamfer import chamfer

    mean, _ = chamfer([r[:, :2] for r in recorded], [f[:, :2] for f in fitted], spacing=1.0)
    return mean


def _pair(recorded: list[np.ndarray], fitted: list[np.ndarray]) -> list[int]:
    """For each recorded stroke, the fitted path drawn over it: in order when the counts
    agree, else by nearest start and end points (one to one)."""
    if len(recorded) == len(fitted):
        return list(range(len(recorded)))
    cost = np.array([[np.linalg.norm(r[0, :2] - f[0, :2]) + np.linalg.norm(r[-1, :2] - f[-1, :2])
                      for f in fitted] for r in recorded])
    rows, cols = linear_sum_assignment(cost)
    return [int(cols[list(rows).index(i)]) if i in rows else -1 for i in range(len(recorded))]


def human_agreement_of_traces(traces: Traces, drawing: Any, png: str | Path, source: str,
                              **options: Any) -> dict[str, Any]:
    """Agreement of ``drawing`` (a :class:`~inkmotion.sigma_lognormal.Drawing` fitted to
    the recording ``source``, read into ``traces`` by the caller) with the recording's timed
    motion; writes the speed plot to ``png``.

    The recording is mapped onto the drawing's canvas as the fit job does
    (``fit_to_canvas(max(canvas))``), the plans are sampled uniformly in time. A recording
    without times gives {"has_times": False, ...} and no plot. ``options`` go to
    :func:`human_agreement`. Reading the file is the kinds' part (it asks the reader
    plugins), so this engine takes the traces."""
    from inkmotion.outputs.sampling import sample

    if traces.meta.get("t") is None:
        missing = traces.meta.get("times_missing")
        why = (f"{missing} of its {traces.meta.get('points')} points carry no time stamp (too "
               "many to fill in from their neighbours)" if missing else
               "the points carry no time stamps")
        return {"has_times": False, "stamped": bool(missing),
                "note": f"{source}: {why}, so there is no recorded speed to compare with."}
    traces = traces.fit_to_canvas(max(drawing.canvas))
    times, unit = times_in_seconds(traces.meta["t"], traces.meta.get("time_unit", "auto"))
    if [len(t) for t in times] != [len(s) for s in traces.strokes]:
        raise InputError(f"{source}: the time stamps do not line up with the points.")
    if not any(advances(t) for t in times):
        return {"has_times": False, "stamped": True, "time_unit": unit,
                "note": f"{source}: its time stamps do not advance along any stroke (all "
                        "the same, or running backwards), so there is no recorded speed to "
                        "compare with."}
    samples = [sample(plan) for plan in drawing.plans]
    apart = _apart(traces.strokes, [s.positions for s in samples])
    index = _pair(traces.strokes, [s.positions for s in samples])
    paired = [i for i, j in enumerate(index) if j >= 0]
    untimed = [i for i in paired if not advances(times[i])  # one time: no speed
               or not _plausible_span(times[i])]
    back = clock_jumps(times)
    jumped = [i for i in paired if i in back and i not in untimed]
    kept = [i for i in paired if i not in untimed and i not in jumped]
    recorded = [(traces.strokes[i], times[i]) for i in kept]
    fit = [(samples[index[i]].positions, samples[index[i]].speed) for i in kept]
    result = human_agreement(recorded, fit, **options)
    rate = float(options.get("rate", 200.0))
    smooth_s = float(options.get("smooth_s", 0.03))
    profiles = [recorded_speed(p, t, rate=rate, smooth_s=smooth_s, unit="s")[:2]
                for p, t in recorded]
    if recorded:
        plot_speed_profiles(png, profiles, [(arc_length(p), s) for p, s in fit])
    size = max(drawing.canvas)
    notes = []
    if apart > APART_SHARE * size:
        notes.append(f"{source}: its strokes lie {apart:.0f} px from the plan's motion on "
                     f"average (on its {size:g}-px canvas; a fit's lie within a pixel or "
                     "two): it does not look like the drawing the plan was fitted to, so "
                     "the speed agreement says little; give the recording the plan was "
                     "fitted to")
    else:
        if untimed:
            notes.append(f"{source}: {len(untimed)} of its {len(paired)} strokes have "
                         "time stamps that do not advance (all the same, or running "
                         f"backwards) or span more than {MAX_STROKE_S / 3600:g} h "
                         f"({_strokes(untimed)}), so they are left out of the speed "
                         "comparison")
        if jumped:
            worst = max(back[i] for i in jumped)
            notes.append(f"{source}: the clock runs backwards inside {len(jumped)} of its "
                         f"{len(paired)} strokes ({_strokes(jumped)}; by up to "
                         f"{worst * 1000:.0f} ms), so they are left out of the speed "
                         "comparison")
        stamps = [int(_new_stamps(times[i]).sum()) for i in kept]
        if stamps and float(np.median(stamps)) < SPARSE_STAMPS:
            notes.append(f"{source}: its strokes hold a median of {np.median(stamps):g} time "
                         "stamps each, too few for a speed profile with a hand's peaks, so "
                         "the peak comparison says little (a recording sampled at 50 Hz or "
                         "more has dozens)")
        if traces.meta.get("times_filled"):
            filled = int(traces.meta["times_filled"])
            notes.append(f"{source}: {filled} of its points {'carries' if filled == 1 else 'carry'}"
                         " no time stamp; "
                         f"{'its was' if filled == 1 else 'theirs were'} filled in from the "
                         "neighbouring points' stamps")
    plot = {"plot": Path(png).name} if recorded else {}
    return {"has_times": True, "time_unit": unit, "strokes_paired": len(kept),
            "strokes_untimed": len(untimed), "strokes_clock_back": len(jumped),
            "apart_px": apart, **plot, **result,
            **({"note": "; ".join(notes)} if notes else {})}
