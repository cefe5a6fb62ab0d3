"""Job kind "fit": a ΣΛ motion fitted to a drawing (the paper's "fitting trajectories to an
image"): read the input, initialise one motor plan per stroke, optimise them through the
differentiable renderer against the image loss and the smoothing cost, write the artifacts.

Artifacts: plan.json, input.json, drawing.svg, drawing.png, overlay.png, speed.png,
trajectory.csv (+ job.json, report.json and recording.rrd from the shell). The report
holds steps, loss terms and T_end before and after, and the Chamfer distance between the
input polylines and the fitted trajectory; its ``metrics`` go to the job store.

Importing this module imports no torch (the command line lists kinds at once).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.jobs.kind import InputSpec
from inkmotion.jobs.params import PluginChoice, param, plugin_param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.shell import Job


@dataclass
class FitParams:
    """Parameters of a fit; defaults are the authors' (DESIGN.md § Fitting defaults) except
    λ: with our renderer and MSE scale λ = 70 pins every Δt at its 0.1 floor and cuts
    corners (49867.json: max Chamfer 6.0 px), while 20 reaches the same T_end (0.14×)
    with a max of 0.9 px."""

    steps: int = param(300, "Adam steps.", minimum=1, maximum=100_000)
    size: int = param(350, "Canvas longer side, px.", minimum=32, maximum=4096)
    width: float = param(3.0, "Stroke width, px.", minimum=0.01, maximum=256)
    lambda_smooth: float = param(20.0, "Weight λ of the smoothing (minimum-time) cost.",
                                 minimum=0, flag="--lambda")
    w_image: float = param(200.0, "Weight of the image loss.", minimum=0)
    w_sigma: float = param(50.0, "Weight of Var(Δt) in the smoothing cost.", minimum=0)
    w_canvas: float = param(1.0, "Weight of the term keeping targets on the canvas.",
                            minimum=0)
    lr_points: float = param(2.0, "Learning rate of the virtual targets, px.", minimum=0)
    lr_delta_t: float = param(0.05, "Learning rate of the overlaps Δt.", minimum=0)
    lr_delta: float = param(0.1, "Learning rate of the turning angles δ.", minimum=0)
    lr_ac: float = param(0.0, "Learning rate of the shapes Ac (0 keeps them fixed).",
                         minimum=0)
    lr_final: float = param(0.1, "Cosine decay of the learning rates to this fraction.",
                            minimum=0, maximum=1)
    samples_per_move: int = param(5, "Bézier segments per lognormal on the fitting grid.",
                                  minimum=1, maximum=100)
    reader: PluginChoice | None = plugin_param(
        "reader", None, "Reader plugin (default: the first that accepts the input).")
    initialiser: PluginChoice = plugin_param("initialiser", "dce", "Initialiser plugin.")
    renderer: PluginChoice = plugin_param("renderer", "raster", "Renderer plugin.")
    losses: list[PluginChoice] = plugin_param("image-loss", "mse",
                                              "Image-loss plugin (repeatable).", many=True,
                                              flag="--loss")

    def validate(self) -> None:
        if not self.losses:
            raise SpecError("The fit job needs at least one image loss (e.g. --loss mse).")


class FitKind:
    """The 'fit' job kind (see the module docstring)."""

    name = "fit"
    description = "Fit a ΣΛ motion to a drawing: a GML/JSON tag, an SVG or text:WORD."
    queue = "optimise"
    inputs = (InputSpec("drawing", "GML/JSON/SVG file, or text:WORD."),)
    Params = FitParams
    examples = (
        "inkmotion run fit text:hello --out results/hello",
        "inkmotion run fit ../shared/data/gml/49867.json --out results/49867 --steps 300",
        "inkmotion run fit tag.gml --out results/smoother --lambda 150 --size 500",
        "inkmotion run fit tag.gml --out results/sparse --dce-threshold 20",
    )

    def steps(self, params: FitParams) -> int:
        return params.steps

    def run(self, job: Job) -> dict[str, Any]:
        return _fit(job)


def _fit(job: Job) -> dict[str, Any]:
    """Read, initialise, optimise, write the artifacts; return the report."""
    import torch

    from inkmotion.fitting.objective import Objective, Weights
    from inkmotion.fitting.optimise import OptimiserSettings, optimise
    from inkmotion.geometry.read import read_input
    from inkmotion.plugin_host.protocols import JobInputs, Reference

    p: FitParams = job.params
    dtype = torch.float32
    source = job.spec.inputs["drawing"]
    traces = read_input(source, reader=p.reader.name if p.reader else None)
    traces = traces.fit_to_canvas(p.size)
    canvas = (int(traces.width), int(traces.height))
    renderer = job.plugin(p.renderer)
    plans = job.plugin(p.initialiser)(JobInputs(canvas, traces=traces), width=p.width,
                                      dtype=dtype, device=job.device,
                                      **job.options(p.initialiser))
    with torch.no_grad():
        target_segments = traces_to_segments(traces, dtype, job.device)
        widths = torch.full((len(target_segments),), p.width, dtype=dtype, device=job.device)
        target = renderer(target_segments, widths, canvas[1], canvas[0])
    losses = {c.name: job.plugin(c).prepare(Reference(image=target), **job.options(c))
              for c in p.losses}
    objective = Objective(renderer, losses, canvas, Weights(
        p.lambda_smooth, p.w_image, p.w_sigma, p.w_canvas, p.samples_per_move))
    settings = OptimiserSettings(p.steps, p.lr_points, p.lr_delta_t, p.lr_delta, p.lr_ac,
                                 p.lr_final)
    job.start(canvas, target, traces.strokes)
    fit = optimise(plans, objective, settings, job.observers)
    return _write(job, traces, fit, canvas, target)


def traces_to_segments(traces: Any, dtype: Any, device: Any) -> Any:
    """Input polylines as straight cubic segments (S, 4, 2), to render the target image."""
    import torch

    parts = []
    for s in traces.strokes:
        pts = torch.as_tensor(s[:, :2], dtype=dtype, device=device)
        a, b = pts[:-1], pts[1:]
        parts.append(torch.stack((a, a + (b - a) / 3, a + 2 * (b - a) / 3, b), dim=1))
    return torch.cat(parts)


def _write(job: Job, traces: Any, fit: Any, canvas: tuple[int, int], target: Any) -> dict:
    """The fit's artifacts (from CPU copies of the plans) and its report."""
    import json

    from inkmotion.geometry.bezier import bezier_segments
    from inkmotion.geometry.chamfer import chamfer
    from inkmotion.outputs import (
        write_overlay,
        write_png,
        write_speed_plot,
        write_svg,
        write_trajectory_csv,
    )
    from inkmotion.outputs.sampling import on_cpu, sample
    from inkmotion.sigma_lognormal import Drawing

    folder = job.folder
    plans = [on_cpu(p) for p in fit.plans]
    size = (float(canvas[0]), float(canvas[1]))
    chamfer_mean, chamfer_max = chamfer(traces.strokes, [sample(p).positions for p in plans])
    t0, t1 = sum(fit.initial_t_end), sum(fit.final_t_end)
    metrics = {"chamfer_mean_px": chamfer_mean, "chamfer_max_px": chamfer_max,
               "t_end_ratio": t1 / t0 if t0 > 0 else float("nan"),
               "moves": sum(p.m for p in plans)}
    report = {
        "steps": fit.steps,
        "fit_s": round(fit.wall_s, 3),
        "paths": len(plans),
        "moves": metrics["moves"],
        "canvas": {"width": canvas[0], "height": canvas[1]},
        "initial_loss": fit.initial_terms,
        "final_loss": fit.final_terms,
        "initial_t_end": t0,
        "final_t_end": t1,
        "t_end_ratio": metrics["t_end_ratio"],
        "chamfer_mean_px": chamfer_mean,
        "chamfer_max_px": chamfer_max,
        "metrics": metrics,
    }
    Drawing(size, plans).save(folder / "plan.json")
    (folder / "input.json").write_text(json.dumps(
        {"canvas": {"width": canvas[0], "height": canvas[1]},
         "traces": [s.tolist() for s in traces.strokes]}))
    segments = [bezier_segments(p).detach() for p in plans]
    write_svg(folder / "drawing.svg", segments, [p.width for p in plans], size)
    rendered = fit.rendered.cpu()
    write_png(folder / "drawing.png", rendered)
    write_overlay(folder / "overlay.png", target.cpu(), rendered, traces=traces.strokes,
                  positions=[p.points.numpy() for p in plans])
    write_speed_plot(folder / "speed.png", plans)
    write_trajectory_csv(folder / "trajectory.csv", plans)
    return report


@hookimpl
def inkmotion_job_kinds() -> list:
    return [FitKind()]
