"""What every figure of ``inkmotion bench`` is: its unit, a short explanation, and the
target it is held to; and the words a met or missed target is reported in.

One table for every benchmark module, so the printed legend cannot miss a figure: a
figure without an entry here is shown as "(no description)" and the test of the suite
fails. Keys that carry a number (``batch_4_fits_per_min``, ``fit_1000px_wall_s``) are
matched by :data:`PATTERNS`.
"""

from __future__ import annotations

import math
import re

#: figure → (unit, what it is); the unit is "" for counts and texts, "×" for ratios
FIGURES: dict[str, tuple[str, str]] = {
    # kinematics
    "kinematics_m150_ms": ("ms", "ΣΛ kinematics of one path of 150 sub-movements (750 "
                                 "samples), forward + backward, median"),
    "kinematics_m500_ms": ("ms", "the same with 500 sub-movements"),
    "kinematics_m2000_ms": ("ms", "the same with 2000 sub-movements"),
    "kinematics_ratio_2000_500": ("×", "m = 2000 over m = 500: 4× the work, so about 4 "
                                       "when the cost grows linearly"),
    "kinematics_host_syncs": ("", "host synchronisations in one kinematics step (each "
                                  "would stall a GPU)"),
    "step_host_syncs": ("", "host synchronisations in one fit step (the objective, "
                            "forward + backward), as this device runs it"),
    "step_host_syncs_static": ("", "the same with static shapes (how a GPU runs it)"),
    # raster
    "raster_ms": ("ms", "the 'raster' renderer: 750 cubic segments, 350×350 px, width 3 px, "
                        "forward + backward, median"),
    "naive_ms": ("ms", "the same scene by the project's dense baseline (every piece against "
                       "every pixel, inkmotion.benchmarks.dense_raster)"),
    "speedup": ("×", "naive_ms / raster_ms: what rendering only the pixels near each piece "
                     "buys"),
    "raster_host_syncs": ("", "host synchronisations in one render + backward"),
    # spray
    "spray_ms": ("ms", "the 'spray' renderer on the raster scene, forward + backward"),
    "spray_raster_ms": ("ms", "'raster' on the same scene in the same run"),
    "spray_vs_raster": ("×", "spray_ms / spray_raster_ms"),
    "spray_host_syncs": ("", "host synchronisations in one spray render + backward"),
    "spray_preview_350_s": ("s", "the seeded spray-paint preview of text:inkmotion at "
                                 "350 px"),
    "spray_preview_4000_s": ("s", "the same preview at 4000 px"),
    # extraction
    "extraction_s": ("s", "decode and trace a 1000 × 1000 scan of a tag (8 px ink, JPEG 70), "
                          "median of 5 after the first"),
    "extraction_first_s": ("s", "the first trace of a process: its libraries' first "
                                "imports and calls"),
    "extraction_decode_s": ("s", "of extraction_s, decoding and the ink map"),
    "extraction_strokes": ("", "strokes traced in that scan"),
    # fit
    "fit_input": ("", "the drawing the timed fit fits (--fit-input)"),
    "fit_steps": ("", "Adam steps of the timed fit (the fit's default)"),
    "fit_steps_run": ("", "the steps it ran (report.json's steps)"),
    "fit_wall_s": ("s", "the whole fit job, default settings (350 px): read, initialise, "
                        "optimise, write (report.json's wall_s)"),
    "fit_warm_wall_s": ("s", "the same job again in the same process, as a worker's later "
                             "jobs run: imports and first calls already paid (with "
                             "--repeat N, the median of N)"),
    "fit_warm_wall_min_s": ("s", "with --repeat N: the fastest of those N"),
    "fit_warm_wall_max_s": ("s", "with --repeat N: the slowest of those N"),
    "fit_ms_per_step": ("ms", "optimiser time per step run (with --repeat N, the median "
                              "over every run)"),
    "fit_moves": ("", "sub-movements (lognormals) of the fitted plan"),
    "fit_chamfer_mean_px": ("px", "mean distance between the input and the fitted "
                                  "trajectory (Chamfer, both ways)"),
    "fit_chamfer_max_px": ("px", "the largest such distance"),
    "fit_t_end_ratio": ("×", "T_end after the fit / before it (below 1: a faster motion)"),
    # recording
    "recording_step_off_ms": ("ms", "a fit step without the rerun recorder (mean, best of "
                                    "2 runs)"),
    "recording_step_on_ms": ("ms", "a fit step with the recorder"),
    "recording_own_ms": ("ms", "time per step spent inside the recorder itself"),
    "recording_ratio": ("×", "recording_step_on_ms / recording_step_off_ms"),
    # queue
    "queue_jobs": ("", "fit jobs submitted to a local Redis and Celery workers"),
    "queue_workers": ("", "worker processes"),
    "queue_steps": ("", "Adam steps per job"),
    "queue_succeeded": ("", "jobs that ended succeeded"),
    "queue_lost": ("", "jobs not finished when the benchmark stopped waiting"),
    "queue_completed_twice": ("", "jobs run more than once or with more than one set of "
                                  "artifacts"),
    "queue_missing_artifacts": ("", "succeeded jobs without a complete report.json"),
    "queue_jobs_per_min": ("/min", "succeeded jobs per minute, first queued to last done"),
    "queue_latency_first_s": ("s", "queue-to-start latency of the first job (idle pool)"),
    "queue_latency_median_s": ("s", "median queue-to-start latency (waiting included)"),
    "queue_latency_p95_s": ("s", "95th percentile of that latency"),
    "queue_latency_max_s": ("s", "largest such latency"),
    "queue_run_median_s": ("s", "median run time of a job on a worker"),
    # generation
    "tag_s_per_step": ("s", "one optimisation step of a 'tag' (CLIP ViT-B-32, random "
                            "weights: speed only)"),
    "tag_300_steps_s": ("s", "a 300-step tag, from the measured steps"),
    "tag_300_steps_cpu_s": ("s", "a 300-step tag on the CPU, from the measured steps (the "
                                 "30 s goal is for a GPU)"),
    "tag_moves": ("", "sub-movements of the tag"),
    "abstract_s_per_step": ("s", "one optimisation step of an 'abstract' (150 targets, "
                                 "clip-visual)"),
    "abstract_moves": ("", "sub-movements of the abstraction"),
    # gallery
    "gallery_jobs": ("", "jobs in the gallery built"),
    "gallery_build_s": ("s", "inkmotion gallery build from scratch, start-up included"),
    "gallery_rebuild_unchanged_s": ("s", "the same build again, nothing changed"),
    "gallery_rebuild_one_more_s": ("s", "the build after one more job"),
    "gallery_rebuild_unchanged": ("", "what the unchanged rebuild said"),
    "gallery_rebuild_one_more": ("", "what the rebuild after one more job said"),
    "gallery_site_own_mb": ("MB", "the site's own files (the artifacts are hard links)"),
    # studio (a newcomer's clicks, headless Chromium)
    "studio_ready_s": ("s", "`inkmotion studio` started until its job processes are warm"),
    "studio_page_ms": ("ms", "the page ready (DOMContentLoaded)"),
    "studio_first_progress_ms": ("ms", "Fit pressed until the page draws the first progress"),
    "studio_fit_shown_s": ("s", "Fit pressed until the motion animates: tempt-1, defaults"),
    "studio_fps": ("/s", "frames of the animation at the ΣΛ speed (the display's rate)"),
    "studio_gcode_s": ("s", "page opened, sample fitted, animated, plotted, G-code "
                            "downloaded (4 clicks)"),
    "studio_three_over_alone": ("×", "the slowest of 3 words fitted at once in 3 tabs / one "
                                     "alone (2 run at once on 2 cores)"),
    # throughput
    "fit_alone_s": ("s", "one default fit of text:hello alone (median of 3 rounds)"),
    "fit_pair_s": ("s", "two such fits side by side, until both ended (median of 3)"),
    "pair_over_alone": ("×", "wall time of 2 fits side by side / one fit alone, the same "
                        "word (median of 3 rounds of alone then pair)"),
    "oversubscribed_2_fits_per_min": ("/min", "2 fits side by side, each taking every "
                                              "core"),
}

#: keys with a number in them: (pattern, unit, what; {0}, {1} are the pattern's groups)
PATTERNS: tuple[tuple[str, str, str], ...] = (
    (r"concurrent_(\d+)_fits_per_min", "/min", "default fits per minute, {0} side by side"),
    (r"batch_(\d+)_fits_per_min", "/min", "default fits per minute, {0} as one batched "
                                          "optimisation"),
)

#: figure → (bound, "≤" or "≥"): the project's speed and correctness targets
TARGETS: dict[str, tuple[float, str]] = {
    "kinematics_m150_ms": (10.0, "≤"),
    "kinematics_ratio_2000_500": (6.0, "≤"),
    "raster_ms": (60.0, "≤"),
    "spray_host_syncs": (0, "≤"),
    "speedup": (3.0, "≥"),
    "fit_wall_s": (3.0, "≤"),  # a default fit of a 350-px tag (issue 32)
    "extraction_s": (0.5, "≤"),  # a 1000 x 1000 picture (issue 33)
    "recording_ratio": (1.1, "≤"),
    "tag_300_steps_s": (30.0, "≤"),  # on a CUDA GPU
    "queue_lost": (0, "≤"),
    "pair_over_alone": (1.3, "≤"),
    "queue_completed_twice": (0, "≤"),
    "studio_page_ms": (1000.0, "≤"),  # issue 34
    "studio_first_progress_ms": (1000.0, "≤"),
    "studio_fps": (50.0, "≥"),
    "studio_gcode_s": (60.0, "≤"),
}


def describe(key: str) -> tuple[str, str]:
    """(unit, what) of a figure; a ``fit_<N>px_…`` figure is the fit's at N px."""
    if key in FIGURES:
        return FIGURES[key]
    sized = re.fullmatch(r"fit_(\d+)px_(.+)", key)
    if sized and f"fit_{sized.group(2)}" in FIGURES:
        unit, what = FIGURES[f"fit_{sized.group(2)}"]
        return unit, f"{what.replace(' (350 px)', '')}, at {sized.group(1)} px"
    for pattern, unit, what in PATTERNS:
        found = re.fullmatch(pattern, key)
        if found:
            return unit, what.format(*found.groups())
    return "", "(no description)"


def show_value(value: object, unit: str) -> str:
    """A figure with its unit: 4 significant digits, counts and texts as they are."""
    if isinstance(value, float):
        text = f"{value:.4g}" if math.isfinite(value) else "not measured"
    else:
        text = str(value)
    if not unit or text == "not measured":
        return text
    return f"{text}{unit}" if unit in ("×", "/min", "/s") else f"{text} {unit}"


def verdict(value: object, bound: float, cmp: str, unit: str = "") -> tuple[bool, str]:
    """(met, words): ``≤ 10 ms, met`` or ``≤ 10 ms, missed by 12 %`` (by the excess itself
    when the bound is 0: ``≤ 0, missed by 5``); a figure that is not a finite number
    misses its target, "not measured"."""
    shown = f"{cmp} {show_value(float(bound), unit) if bound else 0}"
    if isinstance(value, bool) or not isinstance(value, int | float) or \
            not math.isfinite(value):
        return False, f"{shown}, not measured"
    met = value <= bound if cmp == "≤" else value >= bound
    if met:
        return True, f"{shown}, met"
    if bound == 0:
        return False, f"{shown}, missed by {show_value(abs(value), unit)}"
    miss = 100 * ((value / bound - 1) if cmp == "≤" else (1 - value / bound))
    return False, f"{shown}, missed by {miss:.0f} %" if miss >= 9.5 else \
        f"{shown}, missed by {miss:.2g} %"  # 12 %, 2.5 %, 0.18 %: never "by 0 %"
