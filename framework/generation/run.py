"""The 'tag' and 'abstract' job kinds' work: load CLIP (weights checked before anything
else), initialise, optimise the ΣΛ plan through the renderer against the CLIP losses, write
the artifacts.

Both kinds share :func:`optimise_generation` (the compound objective λ·L_smooth + w_I·L_I of
a fit with CLIP image losses, optionally with the stroke radius as a third coordinate,
2.5D) and :func:`write_generation` (the artifacts of a fit, plus init.json / init.png).
The report carries ``clip_weights`` — "random" when the job was asked to run on randomly
initialised weights — and the shell copies it into job.json (``provenance``), so a result
made with random weights can never pass for a real one.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import torch

from inkmotion.errors import InputError, SpecError
from inkmotion.plugin_host.protocols import JobInputs, Reference

if TYPE_CHECKING:
    from inkmotion.clip.model import LoadedClip
    from inkmotion.fitting.optimise import FitResult
    from inkmotion.generation.params import GenerationParams
    from inkmotion.jobs.shell import Job
    from inkmotion.sigma_lognormal.plan import MotorPlan


def load_job_clip(params: GenerationParams, device: torch.device) -> LoadedClip:
    """The job's CLIP model, after checking its weights exist (one sentence saying how to get
    them otherwise): this runs first, before any input is read or anything is written."""
    from inkmotion.clip.model import load_clip, weights_problem

    problem = weights_problem(params.clip_model, params.clip_pretrained, params.clip_weights)
    if problem is not None:
        raise SpecError(problem)
    return load_clip(params.clip_model, params.clip_pretrained, params.clip_weights, device)


def run_tag(job: Job) -> dict[str, Any]:
    """A tag from a word: 'line' start, 'clip-text' loss against the caption."""
    p = job.params
    clip = load_job_clip(p, job.device)
    word = job.spec.inputs["word"].strip()
    if not word:
        raise SpecError("The tag job needs a word (e.g. inkmotion run tag CREAM).")
    caption = p.caption.replace("{word}", word)
    canvas = (p.size, p.size)
    plans = job.plugin(p.initialiser)(
        JobInputs(canvas, caption=caption, targets=p.targets), width=p.width,
        dtype=torch.float32, device=job.device, **job.options(p.initialiser))
    reference = Reference(caption=caption, extra={"clip": clip})
    job.start(canvas)
    fit, init = optimise_generation(job, plans, reference, canvas)
    report = write_generation(job, fit, init, canvas, clip=clip, caption=caption)
    report["word"] = word
    report["caption"] = caption
    return report


def run_abstract(job: Job) -> dict[str, Any]:
    """A one-stroke abstraction of a photo: saliency → 'voronoi-tsp' tour → 'clip-visual'."""
    from inkmotion.images.load import load_image

    p = job.params
    clip = load_job_clip(p, job.device)
    photo = load_image(job.spec.inputs["image"], p.size, device=job.device)  # (3, H, W)
    canvas = (int(photo.shape[2]), int(photo.shape[1]))
    caption = p.caption or None
    reference = Reference(image=photo, caption=caption, extra={"clip": clip})
    saliency = job.plugin(p.saliency)(photo, reference, **job.options(p.saliency))
    if saliency.shape != photo.shape[1:] or not bool(torch.isfinite(saliency).all()):
        raise InputError(f"The saliency plugin {p.saliency.name!r} returned a map of shape "
                         f"{tuple(saliency.shape)} with non-finite values or the wrong size; "
                         "try --saliency spectral.")
    plans = job.plugin(p.initialiser)(
        JobInputs(canvas, image=photo, saliency=saliency, caption=caption, targets=p.targets),
        width=p.width, dtype=torch.float32, device=job.device, **job.options(p.initialiser))
    if len(plans) != 1:
        raise SpecError(f"The initialiser {p.initialiser.name!r} made {len(plans)} paths; an "
                        "abstraction is one path (use voronoi-tsp).")
    job.start(canvas, target=1.0 - photo.mean(0))
    fit, init = optimise_generation(job, plans, reference, canvas)
    report = write_generation(job, fit, init, canvas, clip=clip, caption=caption, photo=photo,
                              saliency=saliency)
    report["saliency"] = p.saliency.name
    return report


def optimise_generation(job: Job, plans: list[MotorPlan], reference: Reference,
                        canvas: tuple[int, int]) -> tuple[FitResult, list[MotorPlan]]:
    """Optimise ``plans`` against the job's image losses bound to ``reference``; returns
    the fit and the start plans (lifted to 3-D with --varying-width)."""
    from inkmotion.fitting.objective import Objective, Weights
    from inkmotion.fitting.optimise import OptimiserSettings, optimise

    p = job.params
    if p.varying_width:
        plans = [plan.with_radius(p.width / 2) for plan in plans]
    losses = {c.name: job.plugin(c).prepare(reference, **job.options(c)) for c in p.losses}
    objective = Objective(job.plugin(p.renderer), losses, canvas, Weights(
        p.lambda_smooth, p.w_image, p.w_sigma, p.w_canvas, p.samples_per_move))
    settings = OptimiserSettings(p.steps, p.lr_points, p.lr_delta_t, p.lr_delta, p.lr_ac,
                                 p.lr_final, lr_radius=p.lr_radius,
                                 radius_range=(p.radius_min, p.radius_max))
    return optimise(plans, objective, settings, job.observers), plans


def render_plans(renderer: Any, plans: list[MotorPlan], canvas: tuple[int, int]
                 ) -> torch.Tensor:
    """Coverage (H, W) of ``plans`` drawn by ``renderer`` (no gradient)."""
    from inkmotion.geometry.bezier import bezier_segments

    with torch.no_grad():
        segments = [bezier_segments(plan) for plan in plans]
        widths = torch.cat([torch.full((s.shape[0],), plan.width, dtype=s.dtype,
                                       device=s.device) for s, plan in zip(segments, plans,
                                                                          strict=True)])
        return renderer(torch.cat(segments), widths, canvas[1], canvas[0])


def clip_similarity(clip: LoadedClip, rendered: torch.Tensor, caption: str | None,
                    photo: torch.Tensor | None) -> float | None:
    """Cosine similarity in CLIP's space between a drawing (coverage (H, W)) and the
    caption, else the photo: the quality figure of a generation (higher is closer)."""
    with torch.no_grad():
        drawing = (1.0 - rendered).expand(3, -1, -1)[None]  # ink black on white
        image = clip.encode_image(drawing)
        if caption:
            other = clip.encode_text([caption]).to(image)
        elif photo is not None:
            other = clip.encode_image(photo[None])
        else:
            return None
        return float((image * other).sum())


def write_generation(job: Job, fit: FitResult, init: list[MotorPlan], canvas: tuple[int, int],
                     *, clip: LoadedClip, caption: str | None = None,
                     photo: torch.Tensor | None = None,
                     saliency: torch.Tensor | None = None) -> dict[str, Any]:
    """The artifacts of a generation (CPU copies of the plans) and its report."""
    from inkmotion.geometry.bezier import bezier_segments
    from inkmotion.outputs import (
        write_overlay,
        write_png,
        write_speed_plot,
        write_svg,
        write_trajectory_csv,
    )
    from inkmotion.outputs.photo import write_on_photo, write_saliency
    from inkmotion.outputs.sampling import on_cpu
    from inkmotion.sigma_lognormal import Drawing

    folder: Path = job.folder
    p = job.params
    plans = [on_cpu(plan) for plan in fit.plans]
    init = [on_cpu(plan) for plan in init]
    size = (float(canvas[0]), float(canvas[1]))
    renderer = job.plugin(p.renderer)
    rendered = fit.rendered.detach().cpu()
    init_rendered = render_plans(renderer, init, canvas)
    Drawing(size, plans).save(folder / "plan.json")
    Drawing(size, init).save(folder / "init.json")
    write_svg(folder / "drawing.svg", [bezier_segments(plan).detach() for plan in plans],
              [plan.width for plan in plans], size)
    write_png(folder / "drawing.png", rendered)
    write_speed_plot(folder / "speed.png", plans)
    write_trajectory_csv(folder / "trajectory.csv", plans)
    if photo is not None:
        photo_cpu = photo.detach().cpu()
        write_on_photo(folder / "init.png", photo_cpu, init_rendered,
                       positions=[plan.points for plan in init])
        write_on_photo(folder / "overlay.png", photo_cpu, rendered)
    else:
        write_png(folder / "init.png", init_rendered)
        write_overlay(folder / "overlay.png", init_rendered, rendered,
                      positions=[plan.points for plan in plans])
    if saliency is not None:
        write_saliency(folder / "saliency.png", saliency.detach().cpu())
    if p.spray_preview:
        from inkmotion.rendering.render_plan import write_spray_png

        write_spray_png(folder / "spray.png", Drawing(size, plans), job.spec.seed)

    t0, t1 = sum(fit.initial_t_end), sum(fit.final_t_end)
    score0 = clip_similarity(clip, init_rendered.to(clip.device), caption,
                             None if photo is None else photo.to(clip.device))
    score1 = clip_similarity(clip, rendered.to(clip.device), caption,
                             None if photo is None else photo.to(clip.device))
    moves = sum(plan.m for plan in plans)
    metrics = {"t_end_ratio": t1 / t0 if t0 > 0 else float("nan"), "moves": moves,
               "clip_similarity": score1}
    return {
        "steps": fit.steps,
        "fit_s": round(fit.wall_s, 3),
        "s_per_step": round(fit.wall_s / max(fit.steps, 1), 4),
        "paths": len(plans),
        "moves": moves,
        "varying_width": bool(p.varying_width),
        "canvas": {"width": canvas[0], "height": canvas[1]},
        "initial_loss": fit.initial_terms,
        "final_loss": fit.final_terms,
        "initial_t_end": t0,
        "final_t_end": t1,
        "t_end_ratio": metrics["t_end_ratio"],
        "clip_model": clip.name,
        "clip_weights": clip.weights,
        "clip_similarity_initial": score0,
        "clip_similarity_final": score1,
        "metrics": metrics,
        "provenance": {"clip_weights": clip.weights, "clip_model": clip.name},
    }
