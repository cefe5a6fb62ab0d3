"""The 'plot' job kind's work: a plan on paper for a pen plotter, as G-code whose feeds
follow the ΣΛ speed.

Steps: 1 machine, paper and timing (everything that can refuse the job: the machine
profile, a v-max or a-max above the machine's, a plan that does not fit the paper); 2 the
stroke order (the drawing's own, or optimised for pen-up travel, reported before and
after); 3 the files: plot.gcode (or plot_pen<N>.gcode, one per pen, when plan.json's paths
name several with ``"pen"``), plot.svg, plot_preview.png, feed.png and report.json with the
machine time estimated by :mod:`inkmotion.plotter.planner`, the distances drawn and
travelled, the peak feed and how closely the feeds follow the plan's speed.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from inkmotion.errors import InputError
from inkmotion.events import StepState

if TYPE_CHECKING:
    from inkmotion.jobs.shell import Job
    from inkmotion.plotter.timing import PlotStroke

STEPS = 3


def plan_pens(path: str, paths: int) -> list[int]:
    """The pen of every path of plan.json (its optional ``"pen"``, a number ≥ 1; 1 when
    absent)."""
    raw = json.loads(Path(path).read_text(encoding="utf-8")).get("paths", [])
    pens = []
    for i, entry in enumerate(raw[:paths]):
        pen = entry.get("pen", 1) if isinstance(entry, dict) else 1
        if isinstance(pen, bool) or not isinstance(pen, int) or pen < 1:
            raise InputError(f"{path}: paths[{i}].pen = {pen!r} is not a pen number ≥ 1; "
                             "fix it or leave it out (pen 1).")
        pens.append(pen)
    return pens


def feed_correlation(strokes: list[PlotStroke]) -> float:
    """Pearson correlation of every segment's feed with the ΣΛ speed at its middle."""
    feeds = np.concatenate([st.feeds for st in strokes] + [np.zeros(0)])
    speed = np.concatenate([st.plan_speed for st in strokes] + [np.zeros(0)])
    if len(feeds) < 3 or np.std(feeds) == 0 or np.std(speed) == 0:
        return float("nan")
    return float(np.corrcoef(feeds, speed)[0, 1])


#: samples per path of the motion checked against the paper before anything is timed
PAPER_SAMPLES = 512


def _check_on_paper(drawing: Any, mapping: Any, paper: tuple[float, float],
                    plan_file: str) -> None:
    """Refuse a plan whose motion leaves the sheet (its points lie off its canvas: an
    edited plan, or a plan of another canvas): G-code past the paper drives the pen
    off it, or into the machine's end stops. Checked on :data:`PAPER_SAMPLES` samples a
    path, before the timing (whose samples follow the motion's length)."""
    import torch

    from inkmotion.sigma_lognormal.kinematics import kinematics

    with torch.no_grad():
        xy = np.vstack([kinematics(plan, torch.linspace(0.0, float(plan.end_time),
                                                        PAPER_SAMPLES)).positions[:, :2]
                        .double().numpy() for plan in drawing.plans])
    uv = mapping.px_to_plane(xy)
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    if lo.min() >= -0.5 and hi[0] <= paper[0] + 0.5 and hi[1] <= paper[1] + 0.5:
        return
    raise InputError(f"{plan_file}: the motion leaves the {paper[0]:g} × {paper[1]:g} mm "
                     f"paper (it reaches x {lo[0]:.0f} to {hi[0]:.0f} mm, y {lo[1]:.0f} to "
                     f"{hi[1]:.0f} mm: its points lie off its {drawing.canvas[0]:g} × "
                     f"{drawing.canvas[1]:g} px canvas); refit the plan or restore its "
                     "points.")


def _past_the_edge(strokes: list[Any], paper: tuple[float, float]) -> float:
    """How far (mm) the farthest drawn point lies outside the paper, 0 when none does."""
    points = np.vstack([st.points for st in strokes])
    outside = np.maximum(np.maximum(-points, points - np.asarray(paper)), 0.0)
    return float(outside.max())


def run_plot(job: Job) -> dict[str, Any]:
    """Time, order and write the plot (module docstring); returns the report."""
    from inkmotion.plotter.gcode import write_gcode
    from inkmotion.plotter.machine import load_machine
    from inkmotion.plotter.order import optimise_order, tour_length
    from inkmotion.plotter.paper import paper_size, place_on_paper
    from inkmotion.plotter.planner import estimate_time
    from inkmotion.plotter.preview import write_feed_plot, write_preview
    from inkmotion.plotter.program import build_program
    from inkmotion.plotter.svg import write_plot_svg
    from inkmotion.plotter.timing import time_for_plotter
    from inkmotion.sigma_lognormal import Drawing

    p = job.params
    plan_file = job.input_file("plan")
    drawing = Drawing.load(plan_file)
    pens = plan_pens(plan_file, len(drawing.plans))
    machine = load_machine(p.machine, p.machine_file or None)
    v_max, a_max = p.v_max or machine.max_feed, p.a_max or machine.max_accel
    if v_max > machine.max_feed:
        raise InputError(f"--v-max {v_max:g} mm/s is above the {machine.name} machine's "
                         f"{machine.max_feed:g} mm/s; lower it or use a machine profile with "
                         "a higher max_feed.")
    if a_max > machine.max_accel:
        raise InputError(f"--a-max {a_max:g} mm/s² is above the {machine.name} machine's "
                         f"{machine.max_accel:g} mm/s²; lower it or use a machine profile "
                         "with a higher max_accel.")
    job.start((int(drawing.canvas[0]), int(drawing.canvas[1])))
    paper = paper_size(p.paper, p.orientation, drawing.canvas)
    mapping = place_on_paper(drawing.canvas, paper, p.margin, p.scale)
    _check_on_paper(drawing, mapping, paper, plan_file)
    timing = time_for_plotter(drawing, mapping, pens, v_max=v_max, a_max=a_max,
                              accel=machine.max_accel, deviation=machine.junction_deviation,
                              step=p.step, junctions=p.junctions)
    job.observers.on_step(StepState(1, STEPS, {}, None, figures={
        "now": "stroke order", "time_scale": timing.time_scale}))

    strokes = timing.strokes
    starts = np.array([st.points[0] for st in strokes])
    ends = np.array([st.points[-1] for st in strokes])
    order, travel_before = [], 0.0
    for pen in sorted({st.pen for st in strokes}):  # each pen is a file of its own: its tour
        own = [i for i, st in enumerate(strokes) if st.pen == pen]
        mine = list(range(len(own)))
        travel_before += tour_length(mine, starts[own], ends[own])
        if p.order == "optimise":
            mine = optimise_order(starts[own], ends[own])
        order += [own[j] for j in mine]
    strokes = [strokes[i] for i in order]
    job.observers.on_step(StepState(2, STEPS, {}, None, figures={
        "now": "G-code", "time_scale": timing.time_scale, "strokes": len(strokes)}))

    folder = job.folder
    pen_numbers = sorted({st.pen for st in strokes})
    files, per_pen = [], {}
    for pen in pen_numbers:
        mine = [st for st in strokes if st.pen == pen]
        blocks = build_program(mine, machine)
        name = "plot.gcode" if len(pen_numbers) == 1 else f"plot_pen{pen}.gcode"
        estimate = estimate_time(blocks, machine)
        comments = [f"inkmotion plot of {plan_file}", f"machine {machine.name}, pen {pen}",
                    f"paper {paper[0]:g} x {paper[1]:g} mm, {mapping.scale:.4g} mm/px",
                    f"estimated {estimate['total_s']:.1f} s"]
        (folder / name).write_text(write_gcode(blocks, machine, comments), encoding="utf-8")
        files.append(name)
        per_pen[str(pen)] = {"file": name, "strokes": len(mine), **estimate,
                             "travel_mm": tour_length(list(range(len(mine))),
                                                      np.array([s.points[0] for s in mine]),
                                                      np.array([s.points[-1] for s in mine]))}
    drawn_mm = float(sum(st.lengths.sum() for st in strokes))
    travel_mm = sum(v["travel_mm"] for v in per_pen.values())
    total_s = sum(v["total_s"] for v in per_pen.values())
    write_plot_svg(folder / "plot.svg", strokes, paper)
    write_preview(folder / "plot_preview.png", strokes, paper,
                  f"{machine.name}: {total_s:.1f} s estimated, drawn {drawn_mm / 1e3:.2f} m, "
                  f"travel {travel_mm / 1e3:.2f} m, peak feed {timing.info['peak_feed']:.1f} "
                  f"mm/s (v-max {v_max:g})")
    write_feed_plot(folder / "feed.png", strokes)
    job.observers.on_step(StepState(3, STEPS, {}, None, figures={"estimated_s": total_s}))
    correlation = feed_correlation(strokes)
    report = {
        "machine": {"name": machine.name, "max_feed": machine.max_feed,
                    "max_accel": machine.max_accel,
                    "junction_deviation": machine.junction_deviation},
        "paper_mm": list(paper), "margin_mm": p.margin, "mm_per_px": mapping.scale,
        "v_max": v_max, "a_max": a_max, "files": files, "pens": per_pen,
        "estimated_s": total_s, "drawn_mm": drawn_mm, "travel_mm": travel_mm,
        "order": p.order, "travel_own_order_mm": travel_before,
        "strokes": len(strokes), "moves": sum(plan.m for plan in drawing.plans),
        "feed_speed_correlation": correlation, "timing": timing.info,
    }
    past = _past_the_edge(strokes, paper)
    if past > 0:
        report["warnings"] = [f"the pen goes up to {past:.3f} mm past the paper's edge (the "
                              "motion's ends overshoot the canvas a little; G-code below 0 can "
                              "trip a machine's soft limits); a --margin of "
                              f"{math.ceil(past * 10) / 10:g} mm or more keeps it on the sheet."]
    report["metrics"] = {"estimated_s": total_s, "peak_feed": timing.info["peak_feed"],
                         "travel_mm": travel_mm, "feed_speed_correlation": correlation}
    return report
