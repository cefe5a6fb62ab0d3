"""The quality benchmark: fit every input with the default settings and measure how good the
fits are, per item and over the set (``inkmotion benchmark``).

It answers "did this change make fitting better?": run it before and after on the same
inputs and compare ``summary.json``. Per item it reports

- ``moves`` m (sub-movements over all paths) beside ``authors_moves``, the m of the
  authors' DCE density on the same input, and the Chamfer distance between the input
  polylines and the fitted trajectory (mean and max, px), from the fit's report;
- ``iou``: intersection over union of the rendered fit and the rendered target, both drawn
  by the 'raster' renderer at the fit's canvas and stroke width and thresholded at a
  coverage of 0.5 (|A ∩ B| / |A ∪ B|);
- ``t_end_ratio`` (T_end after / before the fit: the minimum-time reduction) and
  ``delta_t_at_clamp``, the share of overlaps Δt_i (i ≥ 2; Δt_1 is unused) within 1e-6
  of a bound of :data:`~inkmotion.sigma_lognormal.params.DELTA_T_RANGE` — a high share
  means the smoothing cost pins the plan, which then stops being a model of movement;
- ``steps``, ``fit_s`` (the optimiser) and ``wall_s`` (the whole job);
- :func:`motion_figures`: the fit's speed peaks, against the recorded ones when the input
  has time stamps, and the paper's evaluation ratios minimum jerk / ΣΛ and time-optimal /
  ΣΛ of duration, MSJ and LDJ on the longest path (> 1: ΣΛ better).

Items run in worker processes ('spawn': torch and fork do not mix), each with a fit's
default thread count (:func:`inkmotion.devices.default_threads`), so a row is the fit a
user gets from ``inkmotion run fit`` with the same settings. A failing item
becomes a row holding its one-sentence error; the others go on. Nothing heavy is imported
at module level, so the command line can import this module cheaply.

The output folder is staged (``DIR.partial-*``) and moved into place once the summaries
are written: an interrupted benchmark (Ctrl-C) stops its workers and leaves nothing, not
even the parent folders it created, and a folder that exists is always a complete run.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
import statistics
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from inkmotion.errors import InkmotionError, InputError, SpecError
from inkmotion.json_files import dumps

#: extensions of the recorded drawings a folder input expands to (and pictures of drawings,
#: :data:`inkmotion.images.formats.PICTURE_SUFFIXES`)
DRAWING_SUFFIXES = (".json", ".gml", ".svg")
#: coverage above which a pixel counts as ink for the IoU
INK_THRESHOLD = 0.5
#: the per-item figures the benchmark itself measures: key, column label, unit, meaning
COLUMNS: tuple[tuple[str, str, str, str], ...] = (
    ("moves", "m", "", "sub-movements over all paths"),
    ("authors_moves", "authors' m", "", "sub-movements of the authors' DCE (relevance 2.5)"),
    ("chamfer_mean_px", "Chamfer mean", "px", "input polylines vs fitted trajectory"),
    ("chamfer_max_px", "Chamfer max", "px", "input polylines vs fitted trajectory"),
    ("iou", "IoU", "", "rendered fit vs rendered target, coverage > 0.5"),
    ("t_end_ratio", "T_end ratio", "", "T_end after / before the fit"),
    ("t_end_ratio_multi", "T_end ratio m≥2", "",
     "T_end after / before over the paths of 2 or more sub-movements"),
    ("delta_t_at_clamp", "Δt at clamp", "share", "Δt_i (i ≥ 2) within 1e-6 of 0.1 or 0.9"),
    ("steps", "steps", "", "Adam steps"),
    ("fit_s", "fit", "s", "optimiser wall time"),
    ("wall_s", "wall", "s", "the whole job's wall time"),
    ("fit_speed_peaks", "speed peaks", "", "speed peaks of the fit, all paths"),
    ("recorded_peaks", "recorded peaks", "", "speed peaks of the recording (smoothed)"),
    ("matched_peaks", "matched peaks", "", "fit peaks within 0.1 of arc of a recorded one"),
    ("matched_by_chance", "by chance", "",
     "matched peaks as many fit peaks placed at random would get"),
    ("peaks_f1", "peaks F1", "", "2·matched / (recorded + fit peaks)"),
    ("peak_offset", "peak offset", "arc", "mean |Δs| of matched peaks, arc length 0..1"),
    ("recorded_duration_s", "recorded T", "s", "duration of the recorded motion"),
    ("minjerk_duration", "MJ/ΣΛ T", "", "minimum-jerk duration / ΣΛ's (> 1: ΣΛ faster)"),
    ("minjerk_msj", "MJ/ΣΛ MSJ", "", "> 1: ΣΛ smoother (paper: < 1)"),
    ("minjerk_ldj", "MJ/ΣΛ LDJ", "", "> 1: ΣΛ smoother (paper: > 1)"),
    ("minjerk_msj_equal_duration", "MJ/ΣΛ MSJ·T⁶", "", "MSJ at equal duration, > 1: ΣΛ smoother"),
    ("minjerk_sigma_duration", "MJσ/ΣΛ T", "",
     "minimum jerk through the ΣΛ passage times: duration / ΣΛ's"),
    ("minjerk_sigma_msj", "MJσ/ΣΛ MSJ", "", "> 1: ΣΛ smoother (paper: < 1)"),
    ("minjerk_sigma_ldj", "MJσ/ΣΛ LDJ", "", "> 1: ΣΛ smoother (paper: > 1)"),
    ("minjerk_sigma_msj_equal_duration", "MJσ/ΣΛ MSJ·T⁶", "",
     "MSJ at equal duration, > 1: ΣΛ smoother"),
    ("totg_duration", "TO/ΣΛ T", "", "time-optimal duration / ΣΛ's (paper: < 1)"),
    ("totg_msj", "TO/ΣΛ MSJ", "", "> 1: ΣΛ smoother (paper: > 1)"),
    ("totg_ldj", "TO/ΣΛ LDJ", "", "> 1: ΣΛ smoother (paper: > 1)"),
    ("totg_msj_equal_duration", "TO/ΣΛ MSJ·T⁶", "", "MSJ at equal duration, > 1: ΣΛ smoother"),
)
SUMMARY_FILES = ("summary.json", "summary.csv", "summary.md", "summary.html")


# ----------------------------------------------------------------------------- inputs


def expand_inputs(inputs: Iterable[str]) -> list[str]:
    """Inputs as single sources: a folder becomes its drawings, *.json/*.gml/*.svg and
    pictures (PNG, JPEG, ...), sorted; files and ``scheme:value`` strings pass through (a
    missing file fails in its own row)."""
    from inkmotion.images.formats import PICTURE_SUFFIXES as PICTURES

    sources: list[str] = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            found = sorted(str(f) for f in p.iterdir()
                           if f.is_file() and f.suffix.lower() in DRAWING_SUFFIXES + PICTURES)
            if not found:
                raise InputError(f"{item}: the folder holds no {'/'.join(DRAWING_SUFFIXES)} "
                                 "file and no picture; give drawings or a folder of them.")
            sources.extend(found)
        else:
            sources.append(item)
    if not sources:
        raise SpecError("The benchmark needs at least one input (a drawing, a folder of "
                        "drawings or text:WORD).")
    return sources


def item_names(sources: list[str]) -> list[str]:
    """A distinct, file-system-safe folder name per source (``text:hello`` -> text-hello,
    ``tags/49867.json`` -> 49867; repeats get -2, -3, ...)."""
    from inkmotion.inputs.sources import is_scheme

    names: list[str] = []
    seen: dict[str, int] = {}
    for s in sources:
        base = s.replace(":", "-", 1) if is_scheme(s) else (Path(s).stem or "item")
        base = re.sub(r"[^A-Za-z0-9._-]+", "_", base).strip("._") or "item"
        n = seen.get(base, 0) + 1
        seen[base] = n
        names.append(base if n == 1 else f"{base}-{n}")
    return names


def parse_param(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` -> (KEY, VALUE as JSON, else the string); KEY may be ``PLUGIN.OPTION``
    (e.g. ``initialiser.threshold=20``)."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise SpecError(f"--param {text!r} must read KEY=VALUE, e.g. --param lambda_smooth=40.")
    try:
        value = json.loads(raw)
    except json.JSONDecodeError:
        value = raw
    return key, value


def fit_params(steps: int | None, size: int | None, params: dict[str, Any] | None) -> dict:
    """The fit's ``params`` (JSON) from the options: the defaults unless given. A dotted key
    ``PLUGIN_PARAM.OPTION`` sets an option of the plugin that parameter chooses (its
    default plugin unless the same call names another)."""
    from inkmotion.jobs.params import describe
    from inkmotion.kinds.fit import FitParams

    out: dict[str, Any] = {}
    for key, value in (params or {}).items():
        if "." not in key:
            out[key] = value
    infos = {i.name: i for i in describe(FitParams)}
    for key, value in (params or {}).items():
        if "." not in key:
            continue
        head, _, option = key.partition(".")
        info = infos.get(head)
        if info is None or info.plugin_kind is None or info.many:
            raise SpecError(f"--param {key}: {head!r} is not a fit parameter that chooses one "
                            "plugin (e.g. initialiser.threshold=20).")
        current = out.get(head, info.default.to_dict() if info.default is not None else None)
        current = {"name": current} if isinstance(current, str) else dict(current or {})
        if "name" not in current:
            raise SpecError(f"--param {key}: name the {info.plugin_kind} first, e.g. "
                            f"--param {head}=NAME.")
        current[option] = value
        out[head] = current
    if steps is not None:
        out["steps"] = steps
    if size is not None:
        out["size"] = size
    return out


def default_jobs(n_items: int) -> int:
    """min(cores, items, 4)."""
    from inkmotion.devices import available_cores

    return max(1, min(available_cores(), n_items, 4))


# ----------------------------------------------------------------------------- one item


def quality_figures(item_dir: Path) -> dict[str, float]:
    """IoU of the rendered fit against the rendered target, and the share of Δt_i (i ≥ 2)
    at a clamp bound, from a fit's input.json and plan.json (see the module docstring)."""
    import numpy as np

    import inkmotion
    from inkmotion.evaluation.fit_motion import delta_t_at_clamp
    from inkmotion.geometry.traces import Traces
    from inkmotion.json_files import read_json
    from inkmotion.rendering.drawing import render_plans, render_polylines
    from inkmotion.sigma_lognormal import Drawing

    source = read_json(item_dir / "input.json", InputError, "input file")
    width, height = int(source["canvas"]["width"]), int(source["canvas"]["height"])
    drawing = Drawing.load(item_dir / "plan.json")
    render = inkmotion.plugin("renderer", "raster")
    stroke = drawing.plans[0].width
    traces = Traces([np.asarray(s, dtype=np.float64) for s in source["traces"]])
    target = render_polylines(render, traces.strokes, stroke, (width, height))  # (H, W)
    fitted = render_plans(render, drawing.plans, (width, height))
    a, b = fitted > INK_THRESHOLD, target > INK_THRESHOLD
    union = int((a | b).sum())
    iou = float((a & b).sum()) / union if union else float("nan")
    return {"iou": iou, "delta_t_at_clamp": delta_t_at_clamp(drawing.plans),
            "authors_moves": authors_moves(traces, max(width, height))}


def authors_moves(traces: Any, size: float) -> int:
    """Sub-movements the authors' DCE gives the input (their demo: relevance, turning
    degrees × l1·l2/(l1+l2) ÷ canvas size, above 2.5), the density to compare m with."""
    from inkmotion.initialisers.dce import DEFAULT_RELEVANCE, moves_at, relevance_threshold

    strokes = traces.validated().strokes
    return moves_at(strokes, relevance_threshold(DEFAULT_RELEVANCE, size))


def motion_figures(item_dir: Path, report: dict[str, Any]) -> dict[str, Any]:
    """Speed peaks of the fit, against the recording's when the input has time stamps (from
    the fit's report, which measured them), and the paper's evaluation ratios of its plan
    (:mod:`inkmotion.evaluation.fit_motion`)."""
    from inkmotion.evaluation.fit_motion import evaluation_ratios, report_figures
    from inkmotion.sigma_lognormal import Drawing

    ratios = evaluation_ratios(Drawing.load(Path(item_dir) / "plan.json"))
    return {**report_figures(report), **ratios}


def _flatten(figures: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """{"a": {"b": 1}} -> {"a.b": 1}: nested figures become columns."""
    out: dict[str, Any] = {}
    for k, v in figures.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def run_item(source: str, folder: str, spec: dict[str, Any]) -> dict[str, Any]:
    """Fit ``source`` into ``folder`` and measure it; never raises: a failure is a row with
    ``status: "failed"`` and its one-sentence ``error``. (Runs in a worker process.)"""
    return run_items([(source, folder, spec)])[0]


def run_items(tasks: list[tuple[str, str, dict[str, Any]]]) -> list[dict[str, Any]]:
    """:func:`run_item` of several items fitted as one batched optimisation
    (:func:`inkmotion.jobs.shell.run_jobs_together`; one item: its own fit); a row each."""
    from inkmotion.jobs.shell import Together, run_job, run_jobs_together
    from inkmotion.jobs.spec import JobSpec

    started = time.perf_counter()
    rows = [{"item": Path(folder).name, "source": source, "status": "ok"}
            for source, folder, _ in tasks]
    outcomes: list[Any] = [None] * len(tasks)
    specs: list[Any] = [None] * len(tasks)
    for i, (source, _, spec) in enumerate(tasks):
        try:
            specs[i] = JobSpec.from_dict({**spec, "inputs": {"drawing": source}})
        except Exception as exc:  # noqa: BLE001 - reported in the item's row
            outcomes[i] = exc
    ready = [i for i in range(len(tasks)) if outcomes[i] is None]
    if len(ready) == 1:
        i = ready[0]
        try:
            outcomes[i] = run_job(specs[i], tasks[i][1])
        except Exception as exc:  # noqa: BLE001 - reported in the item's row
            outcomes[i] = exc
    elif ready:
        done = run_jobs_together([Together(specs[i], Path(tasks[i][1])) for i in ready])
        for i, outcome in zip(ready, done, strict=True):
            outcomes[i] = outcome
    return [_row(row, Path(task[1]), outcome, started)
            for row, task, outcome in zip(rows, tasks, outcomes, strict=True)]


def _row(row: dict[str, Any], folder: Path, outcome: Any, started: float) -> dict[str, Any]:
    """An item's row from its fit's report (or the exception it failed with)."""
    if isinstance(outcome, InkmotionError):
        return {**row, "status": "failed", "error": str(outcome),
                "wall_s": round(time.perf_counter() - started, 3)}
    if isinstance(outcome, BaseException):  # a bug, not the user's input: still one row
        return {**row, "status": "failed",
                "error": f"internal error ({type(outcome).__name__}: {outcome}); please "
                         "report it.", "wall_s": round(time.perf_counter() - started, 3)}
    report = outcome
    for key in ("moves", "chamfer_mean_px", "chamfer_max_px", "t_end_ratio",
                "t_end_ratio_multi", "steps", "fit_s", "wall_s", "batch"):
        row[key] = report.get(key)
    try:
        row.update(quality_figures(folder))
        row.update(_flatten(motion_figures(folder, report)))
    except Exception as exc:  # the fit stands; its motion figures are missing, and say so
        row["motion_error"] = f"{type(exc).__name__}: {exc}"
    return row


def _init_worker(threads: int) -> None:
    """Worker start-up: the job shell reads its torch thread count from INKMOTION_THREADS;
    Ctrl-C is the parent's to handle (it stops the workers, then removes the output)."""
    import signal

    os.environ["INKMOTION_THREADS"] = str(threads)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


# ----------------------------------------------------------------------------- the run


def run_benchmark(inputs: list[str], out: Path, *, jobs: int | None = None,
                  steps: int | None = None, size: int | None = None,
                  params: dict[str, Any] | None = None, console: Any = None,
                  device: str = "cpu", seed: int = 0, batch: int = 1,
                  force: bool = False) -> dict:
    """Fit every input into ``out/<item>/`` and write summary.{json,csv,md,html} in ``out``;
    print the aggregate table on ``console`` (a rich Console; None: stdout). Returns the
    summary (``items``, ``aggregate``, ``columns``, ``settings``).

    ``batch`` > 1: each worker fits up to that many items as one batched optimisation
    (:func:`run_items`), the batches taking the items in order.

    Raises :class:`~inkmotion.errors.InkmotionError` for a bad call (no inputs, an empty
    folder, an invalid parameter, an ``out`` that already holds results, unless ``force``)
    before anything runs; a failing item is a row instead. ``out`` appears only once
    complete (module docstring).
    """
    from rich.console import Console

    from inkmotion.devices import default_threads
    from inkmotion.jobs.kind import resolve
    from inkmotion.jobs.spec import JobSpec
    from inkmotion.outputs import StagingDir, refuse_to_overwrite

    console = console or Console()
    sources = expand_inputs(inputs)
    names = item_names(sources)
    spec = JobSpec(kind="fit", inputs={"drawing": sources[0]},
                   params=fit_params(steps, size, params), seed=seed, device=device,
                   record_every=0)
    resolve(spec)  # a bad parameter fails once, here, rather than in every row
    jobs = default_jobs(len(sources)) if jobs is None else jobs
    if jobs < 1:
        raise SpecError(f"--jobs {jobs} must be at least 1.")
    if batch < 1:
        raise SpecError(f"--batch {batch} must be at least 1.")
    jobs = min(jobs, math.ceil(len(sources) / batch))
    threads = default_threads()  # a fit's own default, whatever runs beside it
    out = Path(out)
    refuse_to_overwrite(out, force, inputs=sources)
    created = [p for p in (out, *out.parents) if not p.exists()][1:]  # made by staging
    started = time.perf_counter()
    try:
        with StagingDir(out) as staging:
            assert staging.path is not None
            tasks = [(s, str(staging.path / n), spec.to_dict())
                     for s, n in zip(sources, names, strict=True)]
            rows = _run_all(tasks, jobs, threads, console, batch)
            summary = summarise(rows, wall_s=time.perf_counter() - started)
            summary["settings"] = {"inputs": list(inputs), "jobs": jobs, "batch": batch,
                                   "threads_per_job": threads,
                                   "spec": spec.to_dict() | {"inputs": {}}}
            write_summary(staging.path, summary)
    except BaseException:
        for folder in created:  # closest first; one that holds something else stays
            try:
                folder.rmdir()
            except OSError:
                break
        raise
    print_aggregate(summary, console)
    return summary


def _run_all(tasks: list[tuple[str, str, dict]], jobs: int, threads: int,
             console: Any, batch: int = 1) -> list[dict[str, Any]]:
    """Run the items (in ``jobs`` spawned workers, or here when jobs == 1; ``batch`` items
    at a time per worker) with a progress bar; rows in the order of ``tasks``."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    rows: list[dict[str, Any] | None] = [None] * len(tasks)
    columns = (TextColumn("benchmark"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
               TextColumn("{task.description}"))
    with Progress(*columns, console=console, transient=False) as progress:
        bar = progress.add_task("", total=len(tasks))

        def done(i: int, row: dict[str, Any]) -> None:
            rows[i] = row
            mark = "ok" if row["status"] == "ok" else "FAILED"
            progress.update(bar, advance=1, description=f"{tasks[i][0]}: {mark}")

        chunks = balanced_chunks([t[0] for t in tasks], jobs, batch)
        if jobs == 1:
            for chunk in chunks:
                for i, row in zip(chunk, run_items([tasks[i] for i in chunk]), strict=True):
                    done(i, row)
        else:
            _run_parallel(tasks, chunks, jobs, threads, done)
    assert all(r is not None for r in rows)
    return rows  # type: ignore[return-value]


def balanced_chunks(sources: list[str], jobs: int, batch: int) -> list[list[int]]:
    """The items' indices in batches of at most ``batch`` for ``jobs`` workers: as many
    batches as fill every worker evenly (a multiple of ``jobs``), the items dealt out
    largest first (by the input's size in bytes, text:WORD by its length) in a snake
    order, so every batch carries a similar share of the work and no worker idles at the
    end."""
    if batch <= 1:
        return [[i] for i in range(len(sources))]
    count = max(1, jobs) * math.ceil(len(sources) / (max(1, jobs) * batch))
    count = min(count, len(sources))

    def weight(source: str) -> int:
        try:
            return Path(source).stat().st_size
        except OSError:
            return len(source)

    order = sorted(range(len(sources)), key=lambda i: -weight(sources[i]))
    chunks: list[list[int]] = [[] for _ in range(count)]
    for rank, i in enumerate(order):
        lap, at = divmod(rank, count)
        chunks[at if lap % 2 == 0 else count - 1 - at].append(i)
    return [sorted(c) for c in chunks if c]


def _run_parallel(tasks: list[tuple[str, str, dict]], chunks: list[list[int]], jobs: int,
                  threads: int, done: Callable[[int, dict[str, Any]], None]) -> None:
    import multiprocessing
    from concurrent.futures.process import BrokenProcessPool

    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(jobs, mp_context=context, initializer=_init_worker,
                             initargs=(threads,)) as pool, _stopped_on_interrupt(pool):
        futures = {pool.submit(run_items, [tasks[i] for i in chunk]): chunk for chunk in chunks}
        for future in as_completed(futures):
            chunk = futures[future]
            try:
                rows = future.result()
            except BrokenProcessPool:
                rows = [{"item": Path(tasks[i][1]).name, "source": tasks[i][0],
                         "status": "failed", "error": "its worker process died (out of "
                         "memory or killed); run it alone with --jobs 1 to see why."}
                        for i in chunk]
            for i, row in zip(chunk, rows, strict=True):
                done(i, row)


@contextmanager
def _stopped_on_interrupt(pool: ProcessPoolExecutor) -> Iterator[None]:
    """On Ctrl-C (or any error) in the block: cancel the items not started and stop the
    workers, waiting until they are gone (nothing writes into the output after this)."""
    try:
        yield
    except BaseException:
        processes = list((getattr(pool, "_processes", None) or {}).values())  # shutdown
        pool.shutdown(wait=False, cancel_futures=True)  # forgets them
        for process in processes:
            process.terminate()
        for process in processes:
            process.join()
        raise


# ----------------------------------------------------------------------------- summary


def numeric_keys(rows: list[dict[str, Any]]) -> list[str]:
    """The figure columns: the benchmark's own that some row has (in :data:`COLUMNS`'
    order), then any other numeric ones in order of appearance."""
    own = [k for k, _, _, _ in COLUMNS]
    present = {k for row in rows for k in row}
    extra: list[str] = []
    for row in rows:
        for k, v in row.items():
            if k not in own and k not in extra and _is_number(v):
                extra.append(k)
    return [k for k in own if k in present] + extra


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def aggregate(rows: list[dict[str, Any]], keys: list[str]) -> dict[str, dict[str, float]]:
    """Per column over the succeeded items with a finite value: n, mean, median, min, max."""
    out: dict[str, dict[str, float]] = {}
    for key in keys:
        values = [float(r[key]) for r in rows if r.get("status") == "ok"
                  and _is_number(r.get(key)) and math.isfinite(r[key])]
        if values:
            out[key] = {"n": len(values), "mean": statistics.fmean(values),
                        "median": statistics.median(values), "min": min(values),
                        "max": max(values)}
    return out


def summarise(rows: list[dict[str, Any]], wall_s: float) -> dict:
    """The summary: items, columns (key, label, unit), aggregate and totals."""
    keys = numeric_keys(rows)
    known = {k: {"key": k, "label": label, "unit": unit, "meaning": meaning}
             for k, label, unit, meaning in COLUMNS}
    columns = [known.get(k, {"key": k, "label": k, "unit": "", "meaning": "extra figure"})
               for k in keys]
    failed = [r for r in rows if r["status"] != "ok"]
    totals = {"items": len(rows), "succeeded": len(rows) - len(failed), "failed": len(failed),
              "wall_s": round(wall_s, 3),
              "item_wall_s": round(sum(r.get("wall_s") or 0.0 for r in rows), 3)}
    return {"version": 1, "columns": columns, "aggregate": aggregate(rows, keys),
            "totals": totals, "items": rows}


def write_summary(out: Path, summary: dict) -> None:
    """summary.json, summary.csv, summary.md and summary.html in ``out``."""
    from inkmotion.benchmarks.quality_report import write_html, write_markdown

    (out / "summary.json").write_text(dumps(summary, str, indent=1))
    write_csv(out / "summary.csv", summary)
    write_markdown(out / "summary.md", summary)
    write_html(out / "summary.html", summary)


def write_csv(path: Path, summary: dict) -> None:
    """One row per item: item, source, status, the figure columns, error."""
    keys = [c["key"] for c in summary["columns"]]
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["item", "source", "status", *keys, "error"])
        for row in summary["items"]:
            writer.writerow([row.get("item"), row["source"], row["status"],
                             *(_csv_value(row.get(k)) for k in keys), row.get("error", "")])


def _csv_value(value: Any) -> Any:
    return "" if value is None else value


def format_value(value: Any) -> str:
    """A figure for a table: integers as is, floats with 3 significant digits."""
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:.3g}" if math.isfinite(value) else str(value)
    return str(value)


def aggregate_rows(summary: dict, meaning: bool = False) -> list[list[str]]:
    """The aggregate table as text: column label, unit, mean, median, max, n (and what the
    figure means, with ``meaning``)."""
    rows = []
    for c in summary["columns"]:
        a = summary["aggregate"].get(c["key"])
        if a is None:
            continue
        rows.append([c["label"], c["unit"], format_value(a["mean"]), format_value(a["median"]),
                     format_value(a["max"]), str(a["n"])] + ([c["meaning"]] if meaning else []))
    return rows


AGGREGATE_HEADER = ("figure", "unit", "mean", "median", "max", "n")


def totals_line(summary: dict) -> str:
    t = summary["totals"]
    return (f"{t['items']} items, {t['succeeded']} succeeded, {t['failed']} failed; "
            f"wall {t['wall_s']:.1f} s (items together {t['item_wall_s']:.1f} s)")


def print_aggregate(summary: dict, console: Any) -> None:
    """The aggregate table, the totals and each failure's error on ``console``."""
    from rich.table import Table

    table = Table(*AGGREGATE_HEADER, title="quality benchmark (succeeded items)")
    for row in aggregate_rows(summary):
        table.add_row(*row)
    console.print(table)
    console.print(totals_line(summary), highlight=False)
    for row in summary["items"]:
        if row["status"] != "ok":
            console.print(f"[red]failed[/] {row['item']}: {row['error']}", highlight=False)
