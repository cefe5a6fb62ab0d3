"""The 'evaluate' job kind's work: read the plan (and the recording, so a bad one is
refused before any timing runs), compare the timings of each path (the engine,
:mod:`inkmotion.evaluation.comparison`), and write evaluation.json, evaluation.csv, the
plots (speeds.png, minima.png, human_speeds.png with a recording) and the report. The
progress bar shows the path and the timing being computed.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from inkmotion.events import StepState
from inkmotion.json_files import dumps

if TYPE_CHECKING:
    from inkmotion.evaluation.comparison import Comparison
    from inkmotion.jobs.shell import Job


def run_evaluate(job: Job) -> dict[str, Any]:
    """Time, measure, compare and plot the job's plan: every path (``--path -1``: the
    figures per path and over the whole drawing,
    :func:`inkmotion.evaluation.comparison.total_figures`) or one path."""
    from inkmotion.evaluation import metrics as M
    from inkmotion.evaluation.comparison import (
        METHODS,
        choose_path,
        compare,
        over_paths,
        paper_scale,
        ratios_and_directions,
    )
    from inkmotion.evaluation.human import human_agreement_of_traces
    from inkmotion.evaluation.plots import plot_minima, plot_speeds
    from inkmotion.kinds.read import read_input
    from inkmotion.sigma_lognormal import Drawing

    p = job.params
    drawing = Drawing.load(job.input_file("plan"))
    scale = paper_scale(drawing.canvas, p.setup)
    indices = list(range(len(drawing.plans))) if p.path < 0 else [choose_path(drawing, p.path)]
    shown = choose_path(drawing, p.path)  # the longest, or the one asked for: the plots
    recording = None  # read now: a bad one is refused before the work
    if p.recording:
        recording = (read_input(p.recording) if p.recording_time_unit == "auto" else
                     read_input(p.recording, "gml", {"time_unit": p.recording_time_unit}))
    job.start((int(drawing.canvas[0]), int(drawing.canvas[1])))
    n, count = len(METHODS), len(indices)

    def timed(j: int, k: int) -> None:
        """Timing k of path j is done: the bar says which path and which timing runs now."""
        at, now = (j, METHODS[k]) if k < n else (j + 1, METHODS[0])
        figures = {"path": f"{min(at, count - 1) + 1}/{count}",
                   "now": now if at < count else "plots"}
        job.observers.on_step(StepState(j * n + k, n * count, {}, None, figures=figures))

    per_path: dict[int, Comparison] = {}
    for j, index in enumerate(indices):
        per_path[index] = compare(drawing.plans[index], p.v_max, p.a_max, scale, p.rate,
                                  progress=lambda k, j=j: timed(j, k))
    table = over_paths(per_path)
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
    if recording is not None:
        doc["human"] = human_agreement_of_traces(recording, drawing,
                                                 job.folder / "human_speeds.png", p.recording)
    (job.folder / "evaluation.json").write_text(dumps(doc, float, indent=1))
    write_csv(job.folder / "evaluation.csv", table, ratios,
              per_path if len(per_path) > 1 else None)
    plot_speeds(job.folder / "speeds.png", per_path[shown].timed, scale)
    plot_minima(job.folder / "minima.png", sigma.position, 1.0 / p.rate, drawing.canvas)
    print_table(table, ratios, f"evaluation, {len(indices)} path(s)")
    metrics = {f"{m}_{k}_ratio": v for m, r in ratios.items() for k, v in r.items()}
    human = doc.get("human") or {}
    warnings = [human["note"]] if "note" in human else []
    return {**doc, "metrics": metrics, **({"warnings": warnings} if warnings else {})}


def human_agreement_from_files(recording: str, drawing: Any, png: str | Path,
                               reader: str | None = None,
                               reader_options: dict[str, Any] | None = None,
                               **options: Any) -> dict[str, Any]:
    """The recording read by the reader plugins (the one named ``reader``, with
    ``reader_options``, when given), then its agreement with ``drawing``
    (:func:`inkmotion.evaluation.human.human_agreement_of_traces`, which plots to ``png``)."""
    from inkmotion.evaluation.human import human_agreement_of_traces
    from inkmotion.kinds.read import read_input

    return human_agreement_of_traces(read_input(recording, reader, reader_options), drawing,
                                     png, recording, **options)


def recorded_agreement(source: str, drawing: Any, png: Path, reader: str | None = None,
                       reader_options: dict[str, Any] | None = None
                       ) -> tuple[dict[str, Any] | None, str | None]:
    """Recorded duration and peaks, fit peaks matched to them and their mean offset along
    the trace, and the time stamps' unit, when ``source`` is a file whose points carry time
    stamps (else None); the plot of both speed profiles goes to ``png`` (the fit's report
    and the benchmark). Also what the comparison left out or could not use, as one
    sentence (or None): strokes without a recorded speed, a clock that ran back, stamps
    filled in or missing (nothing of a file with no time stamps at all: an SVG, a
    picture). ``reader``, ``reader_options``: the reader the fit read
    ``source`` with, if it named one."""
    from inkmotion.inputs.sources import is_scheme
    from inkmotion.samples import locate

    path = locate(source)  # a sample:NAME is its shipped file
    if is_scheme(path) or not Path(path).is_file():
        return None, None
    result = human_agreement_from_files(source, drawing, png, reader, reader_options)
    note = result.get("note")
    if not result.get("has_times"):  # said only of a file that has some time stamps
        return None, note if result.get("stamped") else None
    return {**result["total"], "time_unit": result["time_unit"]}, note


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
