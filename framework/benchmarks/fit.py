"""Full-fit benchmark: one job with the default settings, timed end to end."""

from __future__ import annotations

import tempfile
from pathlib import Path

from inkmotion.jobs.spec import JobSpec

#: the fit benchmark's input: a real recorded tag shipped with the package
DEFAULT_SAMPLE = "tempt-1"
#: the input when the samples are not installed
FALLBACK_INPUT = "text:inkmotion"


def default_fit_input() -> str:
    """``sample:tempt-1`` (a recorded graffiti tag shipped with inkmotion, see
    ``inkmotion samples``), or ``text:inkmotion`` where that sample cannot be read (an
    installation without the samples)."""
    from inkmotion.errors import InkmotionError
    from inkmotion.kinds.read import read_input

    source = f"sample:{DEFAULT_SAMPLE}"
    try:
        read_input(source)
    except InkmotionError:
        return FALLBACK_INPUT
    return source


def bench_fit(input: str | None = None, steps: int | None = None, size: int = 350,
              device: str = "cpu", warm: bool = False, repeat: int = 1
              ) -> dict[str, float | str]:
    """Job time of a full fit (the fit kind's default settings, ``steps`` if given) and its
    quality figures, with the plan's size (lognormals) beside them. The job runs with a
    fit's default thread count, as ``inkmotion run fit`` does (not ``bench --threads``,
    which sets the other figures' torch threads). ``warm``: the same job ``repeat`` times
    more in this process, whose imports and first calls are then paid, as a worker's
    later jobs find them (``fit_warm_wall_s``, their median; with ``repeat`` > 1 also
    their fastest and slowest, and the optimiser's time per step is the median over
    every run: on a machine whose speed drifts, one run says little)."""
    import statistics
    from dataclasses import fields

    from inkmotion.devices import DEFAULT_THREADS
    from inkmotion.inputs.sources import is_scheme
    from inkmotion.jobs.shell import run_job
    from inkmotion.kinds.fit import FitParams

    source = input or default_fit_input()
    if steps is None:
        steps = next(f.default for f in fields(FitParams) if f.name == "steps")
    spec = JobSpec(kind="fit", inputs={"drawing": source}, device=device,
                   params={"steps": steps, "size": size}, threads=DEFAULT_THREADS)
    with tempfile.TemporaryDirectory() as tmp:
        report = run_job(spec, Path(tmp) / "out")
        again = [run_job(spec, Path(tmp) / f"again-{k}")
                 for k in range(max(1, repeat) if warm else 0)]
    suffix = "" if size == 350 else f"_{size}px"
    warm_walls = [r["wall_s"] for r in again]
    warm_figures: dict[str, float] = {}
    if warm_walls:
        warm_figures[f"fit{suffix}_warm_wall_s"] = statistics.median(warm_walls)
    if len(warm_walls) > 1:
        warm_figures[f"fit{suffix}_warm_wall_min_s"] = min(warm_walls)
        warm_figures[f"fit{suffix}_warm_wall_max_s"] = max(warm_walls)
    per_step = statistics.median(r["fit_s"] / max(int(r["steps"]), 1)
                                 for r in [report, *again])
    return {
        "fit_input": source if is_scheme(source) else Path(source).name,
        "fit_steps": steps,
        f"fit{suffix}_steps_run": int(report["steps"]),
        f"fit{suffix}_wall_s": report["wall_s"],
        **warm_figures,
        f"fit{suffix}_ms_per_step": 1e3 * per_step,
        f"fit{suffix}_moves": report["moves"],
        f"fit{suffix}_chamfer_mean_px": report["chamfer_mean_px"],
        f"fit{suffix}_chamfer_max_px": report["chamfer_max_px"],
        f"fit{suffix}_t_end_ratio": report["t_end_ratio"],
    }
