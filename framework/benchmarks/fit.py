"""Full-fit benchmark: one job with the default settings, timed end to end."""

from __future__ import annotations

import tempfile
from pathlib import Path

from inkmotion.jobs.spec import FitParams, JobSpec


def shared_dir() -> Path:
    """The ``shared/`` folder beside the repository (sample data, baselines), if any."""
    import os

    env = os.environ.get("INKMOTION_SHARED_DIR")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2].parent / "shared"


def default_fit_input() -> str:
    tag = shared_dir() / "data" / "gml" / "49867.json"
    return str(tag) if tag.is_file() else "text:inkmotion"


def bench_fit(input: str | None = None, steps: int = 300) -> dict[str, float | str]:
    """Wall time of a full fit (default settings) and its quality figures."""
    from inkmotion.jobs.runner import run_job

    spec = JobSpec(kind="fit", input=input or default_fit_input(),
                   params=FitParams(steps=steps))
    with tempfile.TemporaryDirectory() as tmp:
        report = run_job(spec, Path(tmp) / "out", progress=False)
    return {
        "fit_input": Path(spec.input).name if not spec.input.startswith("text:") else spec.input,
        "fit_steps": steps,
        "fit_wall_s": report["wall_s"],
        "fit_ms_per_step": 1e3 * report["fit_s"] / steps,
        "fit_chamfer_mean_px": report["chamfer_mean_px"],
        "fit_chamfer_max_px": report["chamfer_max_px"],
        "fit_t_end_ratio": report["t_end_ratio"],
    }
