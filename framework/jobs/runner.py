"""Run one job in-process: read, initialise, optimise, write artifacts atomically.

``inkmotion run`` calls :func:`run_job` directly; Celery workers call the same function,
so both write the same artifacts: plan.json, input.json, drawing.svg, drawing.png,
overlay.png, speed.png, trajectory.csv, job.json, report.json (and recording.rrd when a
recorder observes the run).
"""

from __future__ import annotations

import json
import platform
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from inkmotion.errors import SpecError
from inkmotion.fitting.objective import Objective, Weights
from inkmotion.fitting.optimise import optimise
from inkmotion.geometry.bezier import bezier_segments
from inkmotion.geometry.chamfer import chamfer
from inkmotion.geometry.read import read_input
from inkmotion.geometry.traces import Traces
from inkmotion.jobs.observers import Observer, RunContext
from inkmotion.jobs.spec import JobSpec
from inkmotion.outputs import (
    StagingDir,
    write_overlay,
    write_png,
    write_speed_plot,
    write_svg,
    write_trajectory_csv,
)
from inkmotion.plugin_host import host
from inkmotion.sigma_lognormal import Drawing, MotorPlan
from inkmotion.sigma_lognormal.kinematics import kinematics


def resolve_device(name: str) -> torch.device:
    """The torch device for a spec's ``device`` ("cpu", "cuda", "cuda:1", "auto")."""
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except RuntimeError as exc:
        raise SpecError(f"device={name!r} is not a torch device; use cpu, cuda or auto.") from exc
    if device.type == "cuda" and not torch.cuda.is_available():
        raise SpecError(f"device={name!r} was asked for but no CUDA GPU is available; "
                        "use --device cpu.")
    return device


def traces_to_segments(traces: Traces, dtype: torch.dtype,
                       device: torch.device) -> torch.Tensor:
    """Input polylines as straight cubic segments (S, 4, 2), to render the target image."""
    parts = []
    for s in traces.strokes:
        p = torch.as_tensor(s[:, :2], dtype=dtype, device=device)
        a, b = p[:-1], p[1:]
        parts.append(torch.stack((a, a + (b - a) / 3, a + 2 * (b - a) / 3, b), dim=1))
    return torch.cat(parts)


def trajectory_samples(plans: list[MotorPlan], per_move: int = 20) -> list[np.ndarray]:
    """Dense positions of each fitted trajectory, for the Chamfer distance."""
    out = []
    for p in plans:
        t = torch.linspace(0.0, float(p.end_time), per_move * p.m + 1, dtype=torch.float64)
        out.append(kinematics(p.to(dtype=torch.float64), t).positions.numpy())
    return out


def _versions() -> dict[str, str]:
    import inkmotion

    return {"inkmotion": inkmotion.__version__, "torch": torch.__version__,
            "numpy": np.__version__, "python": platform.python_version()}


def run_job(spec: JobSpec, out_dir: str | Path, observers: Sequence[Observer] = (),
            progress: bool = True) -> dict:
    """Execute ``spec`` and place its artifacts in ``out_dir`` atomically; return the report.

    Raises :class:`inkmotion.errors.InkmotionError` subclasses for user-caused failures
    (bad input, unknown plugin); nothing is left in ``out_dir`` then.
    """
    spec.validate()
    params = spec.params
    device = resolve_device(spec.device)
    dtype = torch.float32
    torch.manual_seed(spec.seed)
    started = time.perf_counter()

    plugins = host()
    traces = read_input(spec.input, reader=spec.reader).fit_to_canvas(params.size)
    canvas = (int(traces.width), int(traces.height))
    initialiser = plugins.get("initialiser", spec.initialiser)
    renderer = plugins.get("renderer", spec.renderer)
    plans = initialiser(traces, threshold=params.dce_threshold, width=params.width,
                        dtype=dtype, device=device)
    with torch.no_grad():
        target_segments = traces_to_segments(traces, dtype, device)
        target = renderer(target_segments,
                          torch.full((len(target_segments),), params.width, dtype=dtype,
                                     device=device), canvas[1], canvas[0])
    losses = {name: plugins.get("image-loss", name).prepare(target) for name in spec.losses}
    objective = Objective(renderer, losses, canvas, Weights(
        params.lambda_smooth, params.w_image, params.w_sigma, params.w_canvas,
        params.samples_per_move))

    out_dir = Path(out_dir)
    with StagingDir(out_dir) as staging:
        ctx = RunContext(spec, staging.path, canvas, target, traces.strokes,
                         len(plans), sum(p.m for p in plans))
        for o in observers:
            if hasattr(o, "on_start"):
                o.on_start(ctx)
        bar = _progress_bar(params.steps) if progress else None
        try:
            fit = optimise(plans, objective, params, observers,
                           progress=bar.update if bar else None)
        finally:
            if bar:
                bar.close()

        fitted = trajectory_samples(fit.plans)
        chamfer_mean, chamfer_max = chamfer(traces.strokes, fitted)
        t0, t1 = sum(fit.initial_t_end), sum(fit.final_t_end)
        report = {
            "steps": fit.steps,
            "wall_s": round(time.perf_counter() - started, 3),
            "fit_s": round(fit.wall_s, 3),
            "paths": len(fit.plans),
            "moves": sum(p.m for p in fit.plans),
            "canvas": {"width": canvas[0], "height": canvas[1]},
            "initial_loss": fit.initial_terms,
            "final_loss": fit.final_terms,
            "initial_t_end": t0,
            "final_t_end": t1,
            "t_end_ratio": t1 / t0 if t0 > 0 else float("nan"),
            "chamfer_mean_px": chamfer_mean,
            "chamfer_max_px": chamfer_max,
            "device": str(device),
        }
        _write_artifacts(staging.path, spec, traces, fit, canvas, target, report)
        for o in observers:
            if hasattr(o, "on_end"):
                o.on_end(report)
        staging.commit()
    return report


def _write_artifacts(folder: Path, spec: JobSpec, traces: Traces, fit: object,
                     canvas: tuple[int, int], target: torch.Tensor, report: dict) -> None:
    plans: list[MotorPlan] = fit.plans  # type: ignore[attr-defined]
    Drawing((float(canvas[0]), float(canvas[1])), plans).save(folder / "plan.json")
    (folder / "input.json").write_text(json.dumps(
        {"canvas": {"width": canvas[0], "height": canvas[1]},
         "traces": [s.tolist() for s in traces.strokes]}))
    segments = [bezier_segments(p).detach().cpu() for p in plans]
    write_svg(folder / "drawing.svg", [s[..., :2] for s in segments],
              [p.width for p in plans], (float(canvas[0]), float(canvas[1])))
    rendered = fit.rendered.cpu()  # type: ignore[attr-defined]
    write_png(folder / "drawing.png", rendered)
    write_overlay(folder / "overlay.png", target.cpu(), rendered, traces=traces.strokes,
                  positions=[p.points.detach().cpu().numpy() for p in plans])
    write_speed_plot(folder / "speed.png", plans)
    write_trajectory_csv(folder / "trajectory.csv", plans)
    job = {"spec": spec.to_dict(), "versions": _versions(), "seed": spec.seed}
    (folder / "job.json").write_text(json.dumps(job, indent=1))
    (folder / "report.json").write_text(json.dumps(report, indent=1))


class _progress_bar:  # noqa: N801 - used like a function
    """A tqdm bar showing the loss terms and T_end (stderr, so stdout stays clean)."""

    def __init__(self, total: int) -> None:
        from tqdm.auto import tqdm

        self._bar = tqdm(total=total, desc="fit", unit="step", dynamic_ncols=True, leave=False)

    def update(self, step: int, terms: dict[str, float], t_end: float) -> None:
        shown = {k: f"{v:.4g}" for k, v in terms.items() if k not in ("total", "t_end")}
        shown["T_end"] = f"{t_end:.3g}"
        self._bar.set_postfix(shown, refresh=False)
        self._bar.update(1)

    def close(self) -> None:
        self._bar.close()
