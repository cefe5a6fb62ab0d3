"""The 'tag' and 'abstract' job kinds' work (CLIP-driven generation): load CLIP (weights
checked before anything else), initialise, optimise the ΣΛ plan through the renderer
against the CLIP losses, write the artifacts. The plugins :mod:`inkmotion.plugins.tag`
and :mod:`inkmotion.plugins.abstract` declare the kinds.

Both optimise through the one core (:mod:`inkmotion.kinds.optimisation`): the compound
objective λ·L_smooth + w_I·L_I of a fit with CLIP image losses, optionally with the stroke
radius as a third coordinate (2.5D), as one stage of the staged fit — so a tag or an
abstraction checkpoints and resumes after its worker dies like a fit. They write the
plan's artifacts plus init.json / init.png (and saliency.png for an abstraction). The
report carries ``clip_weights`` — "random" when the job was asked to run on randomly
initialised weights — and the shell copies it into job.json (``provenance``), so a result
made with random weights can never pass for a real one.

Defaults follow the paper's CLIP applications (ClipDraw / CLIPasso settings at a 224-px
canvas, the CLIP input size) where it gives them; the rest are ours and say why. Importing
this module imports no torch: the command line builds its options from these classes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.clip.weights import DEFAULT_MODEL as DEFAULT_CLIP_MODEL
from inkmotion.clip.weights import DEFAULT_PRETRAINED as DEFAULT_CLIP_PRETRAINED
from inkmotion.errors import InputError, SpecError
from inkmotion.jobs.params import PluginChoice, param, plugin_param, redefault
from inkmotion.kinds.optimisation import OptimisationParams, initial_plans

if TYPE_CHECKING:
    import torch

    from inkmotion.clip.model import LoadedClip
    from inkmotion.fitting.stages import StagedFit
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import Reference
    from inkmotion.sigma_lognormal.plan import MotorPlan

DEFAULT_CAPTION = "{word}, a stylish graffiti tag"


@dataclass
class GenerationParams(OptimisationParams):
    """What every CLIP-driven job shares; each kind adds its inputs and overrides defaults."""

    steps: int = redefault(OptimisationParams, "steps", 300)
    size: int = redefault(OptimisationParams, "size", 224,
                          "Canvas longer side, px (CLIP sees 224 px).")
    width: float = redefault(OptimisationParams, "width", 4.0,
                             "Stroke width, px (the start width with --varying-width).")
    lambda_smooth: float = redefault(OptimisationParams, "lambda_smooth", 1.0)
    w_image: float = redefault(OptimisationParams, "w_image", 10.0,
                               "Weight of the image (CLIP) loss.")
    w_sigma: float = redefault(OptimisationParams, "w_sigma", 50.0)
    lr_points: float = redefault(OptimisationParams, "lr_points", 1.0)
    lr_final: float = redefault(OptimisationParams, "lr_final", 0.1)
    max_turn: float = redefault(OptimisationParams, "max_turn", 90.0)
    lr_delta: float = redefault(OptimisationParams, "lr_delta", 0.1)  # for ±90°, as ever
    lr_ac: float = redefault(OptimisationParams, "lr_ac", 0.0)
    targets: int = param(30, "Number of virtual targets (sub-movements) to start from.",
                         minimum=1, maximum=5000)
    varying_width: bool = param(False, "Optimise the stroke radius along the path (2.5D).")
    #: px, the clamp of the radius. Below 0.5 px (a 1-px line) the coverage
    #: clamp(r + ½ − d, 0, 1) never reaches full ink and a stroke could fade out to cheat
    #: the image loss (a pen lift the motor plan does not have); 4 px (an 8-px brush, 2.3 %
    #: of a 350-px canvas) brackets a 3-px pen generously without letting strokes blot out
    #: the shape, and bounds the renderer's patch size
    radius_min: float = param(0.5, "Smallest stroke radius, px, with --varying-width.",
                              minimum=0)
    radius_max: float = param(4.0, "Largest stroke radius, px, with --varying-width.",
                              minimum=0)
    #: px per step. Adam moves a parameter by about its learning rate per step, so 0.1 px
    #: crosses the whole default range (3.5 px) in ~40 steps of a 300-step fit, while one
    #: step changes a stroke's width by ≤ 0.2 px, well inside the 1-px anti-aliasing ramp
    #: whose gradient drives it (targets move 10–20× faster: they travel tens of px, a
    #: radius a few)
    lr_radius: float = param(0.1, "Learning rate of the stroke radius, px.", minimum=0)
    clip_model: str = param(DEFAULT_CLIP_MODEL,
                            "open_clip model name, or an open_clip model-config JSON file.")
    clip_pretrained: str = param(DEFAULT_CLIP_PRETRAINED,
                                 "open_clip pretrained tag of the model's weights.")
    clip_weights: str = param(
        "auto", "Weights: auto (open_clip's cache), a checkpoint file, or random (tests only).")

    def validate(self) -> None:
        if self.varying_width and self.radius_min > self.radius_max:
            raise SpecError(f"--radius-min {self.radius_min} is above --radius-max "
                            f"{self.radius_max}; swap them.")
        if not self.clip_weights.strip():
            raise SpecError("--clip-weights is empty; give auto, a checkpoint file or random.")
        check_one_clip(self)


@dataclass
class TagParams(GenerationParams):
    """Parameters of a tag (the shared ones are :class:`GenerationParams`)."""

    caption: str = param(DEFAULT_CAPTION, "Caption CLIP matches; {word} is replaced by the word.")
    initialiser: PluginChoice = plugin_param("initialiser", "line", "Initialiser plugin.")
    losses: list[PluginChoice] = plugin_param("image-loss", "clip-text",
                                              "Image-loss plugin (repeatable).", many=True,
                                              flag="--loss")

    def validate(self) -> None:
        super().validate()
        if not self.losses:
            raise SpecError("The tag job needs at least one image loss (e.g. --loss clip-text).")


@dataclass
class AbstractParams(GenerationParams):
    """Parameters of an abstraction (the shared ones are :class:`GenerationParams`)."""

    targets: int = param(150, "Number of virtual targets of the tour (the paper's 150).",
                         minimum=2, maximum=5000)
    width: float = redefault(OptimisationParams, "width", 2.0,
                             "Stroke width, px (the start width with --varying-width).")
    caption: str = param("", "Optional caption, used by caption-aware saliency (clip).")
    saliency: PluginChoice = plugin_param("saliency", "spectral",
                                          "Saliency plugin that places the targets.")
    initialiser: PluginChoice = plugin_param("initialiser", "voronoi-tsp",
                                             "Initialiser plugin.")
    losses: list[PluginChoice] = plugin_param("image-loss", "clip-visual",
                                              "Image-loss plugin (repeatable).", many=True,
                                              flag="--loss")

    def validate(self) -> None:
        super().validate()
        if not self.losses:
            raise SpecError("The abstract job needs at least one image loss "
                            "(e.g. --loss clip-visual).")


#: a CLIP loss's own model options (used when it runs outside a generation job) and their
#: defaults; inside a tag or abstract job the job's --clip-* parameters choose the model
_LOSS_CLIP_OPTIONS = {"model": DEFAULT_CLIP_MODEL, "pretrained": DEFAULT_CLIP_PRETRAINED,
                      "weights": "auto"}


def check_one_clip(params: GenerationParams) -> None:
    """Refuse a loss-level CLIP choice (e.g. --clip-text-weights) that differs from its
    default: a generation job loads one CLIP model for all its plugins, chosen by
    --clip-model, --clip-pretrained and --clip-weights."""
    for choice in getattr(params, "losses", []) or []:
        for key, default in _LOSS_CLIP_OPTIONS.items():
            value = choice.options.get(key, default)
            if value != default:
                raise SpecError(f"--{choice.name}-{key} {value} is not used by this job, which "
                                f"loads one CLIP model for all its plugins; give --clip-{key} "
                                f"{value} instead.")


def load_job_clip(params: GenerationParams, device: torch.device) -> LoadedClip:
    """The job's CLIP model, after checking its weights exist (one sentence saying how to get
    them otherwise; no model is built for that). A kind reads and checks its input before
    (a bad input costs no model). Random weights are not warned of here: the job's report
    says so, once (:func:`write_generation`)."""
    import warnings

    from inkmotion.clip.model import RANDOM_WARNING, load_clip, weights_problem

    problem = weights_problem(params.clip_model, params.clip_pretrained, params.clip_weights)
    if problem is not None:
        raise SpecError(problem)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=RANDOM_WARNING)
        return load_clip(params.clip_model, params.clip_pretrained, params.clip_weights,
                         device)


def run_tag(job: Job) -> dict[str, Any]:
    """A tag from a word: 'line' start, 'clip-text' loss against the caption."""
    import torch

    from inkmotion.plugin_host.protocols import JobInputs, Reference

    p = job.params
    word = job.spec.inputs["word"].strip()  # the cheapest check first
    if not word:
        raise SpecError("The tag job needs a word (e.g. inkmotion run tag CREAM).")
    clip = load_job_clip(p, job.device)  # the weights' files checked, then the model built
    caption = p.caption.replace("{word}", word)
    canvas = (p.size, p.size)
    plans = initial_plans(job, p.initialiser, JobInputs(canvas, caption=caption,
                                                        targets=p.targets),
                          width=p.width, dtype=torch.float32, device=job.device)
    reference = Reference(caption=caption, extra={"clip": clip})
    job.start(canvas)
    staged, init = optimise_generation(job, plans, reference, canvas)
    report = write_generation(job, staged, init, canvas, clip=clip, caption=caption)
    report["word"] = word
    report["caption"] = caption
    tokens, context = clip.tokens_cut(caption)
    if tokens > context > 0:
        report["warnings"] = [*report.get("warnings", []), (
            f"the caption is {tokens} CLIP tokens and CLIP reads {context}: its last "
            f"{tokens - context} are cut off unseen (for a long word, its end and \"{p.caption}"
            "\"'s words after {word}); give a shorter word or --caption.")]
    return report


def run_abstract(job: Job) -> dict[str, Any]:
    """A one-stroke abstraction of a photo: saliency → 'voronoi-tsp' tour → 'clip-visual'."""
    import torch

    from inkmotion.images.load import load_image
    from inkmotion.plugin_host.protocols import JobInputs, Reference

    p = job.params
    photo = load_image(job.input_file("image"), p.size, device=job.device)  # (3, H, W)
    clip = load_job_clip(p, job.device)  # after the photo: a bad file costs no model
    canvas = (int(photo.shape[2]), int(photo.shape[1]))
    caption = p.caption or None
    reference = Reference(image=photo, caption=caption, extra={"clip": clip})
    saliency = job.plugin(p.saliency)(photo, reference, **job.options(p.saliency))
    if saliency.shape != photo.shape[1:] or not bool(torch.isfinite(saliency).all()):
        raise InputError(f"The saliency plugin {p.saliency.name!r} returned a map of shape "
                         f"{tuple(saliency.shape)} with non-finite values or the wrong size; "
                         "try --saliency spectral.")
    plans = initial_plans(
        job, p.initialiser,
        JobInputs(canvas, image=photo, saliency=saliency, caption=caption, targets=p.targets),
        width=p.width, dtype=torch.float32, device=job.device)
    if len(plans) != 1:
        raise SpecError(f"The initialiser {p.initialiser.name!r} made {len(plans)} paths; an "
                        "abstraction is one path (use voronoi-tsp).")
    job.start(canvas, target=1.0 - photo.mean(0))
    staged, init = optimise_generation(job, plans, reference, canvas)
    report = write_generation(job, staged, init, canvas, clip=clip, caption=caption,
                              photo=photo, saliency=saliency)
    report["saliency"] = p.saliency.name
    return report


def optimise_generation(job: Job, plans: list[MotorPlan], reference: Reference,
                        canvas: tuple[int, int]) -> tuple[StagedFit, list[MotorPlan]]:
    """Optimise ``plans`` against the job's image losses bound to ``reference`` (one stage
    of the core, checkpointed); returns the fit and the start plans (lifted to 3-D with
    --varying-width)."""
    from inkmotion.fitting.objective import Objective
    from inkmotion.kinds.optimisation import image_losses, optimise_plans, staged_problem

    p = job.params
    if p.varying_width:
        plans = [plan.with_radius(p.width / 2) for plan in plans]
    objective = Objective(job.renderer(p.renderer), image_losses(job, reference), canvas,
                          p.weights())
    settings = p.optimiser_settings(lr_radius=p.lr_radius,
                                    radius_range=(p.radius_min, p.radius_max))
    return optimise_plans(staged_problem(job, plans, objective, settings)), plans


def clip_similarity(clip: LoadedClip, rendered: torch.Tensor, caption: str | None,
                    photo: torch.Tensor | None) -> float | None:
    """Cosine similarity in CLIP's space between a drawing (coverage (H, W)) and the
    caption, else the photo: the quality figure of a generation (higher is closer)."""
    import torch

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


def write_generation(job: Job, staged: StagedFit, init: list[MotorPlan],
                     canvas: tuple[int, int], *, clip: LoadedClip, caption: str | None = None,
                     photo: torch.Tensor | None = None,
                     saliency: torch.Tensor | None = None) -> dict[str, Any]:
    """The artifacts of a generation (CPU copies of the plans) and its report."""
    from inkmotion.kinds.optimisation import plan_report, write_plan_artifacts
    from inkmotion.outputs import write_overlay, write_png
    from inkmotion.outputs.photo import write_on_photo, write_saliency
    from inkmotion.outputs.sampling import on_cpu
    from inkmotion.rendering.drawing import render_plans
    from inkmotion.sigma_lognormal import Drawing

    folder = job.folder
    p = job.params
    plans = [on_cpu(plan) for plan in staged.result.plans]
    init = [on_cpu(plan) for plan in init]
    size = (float(canvas[0]), float(canvas[1]))
    rendered = staged.result.rendered.detach().cpu()
    init_rendered = render_plans(job.renderer(p.renderer), init, canvas)
    report = plan_report(job, staged, plans, canvas)
    report.update(write_plan_artifacts(job, plans, rendered, canvas))
    Drawing(size, init).save(folder / "init.json")
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
    photo_on = None if photo is None else photo.to(clip.device)
    score0 = clip_similarity(clip, init_rendered.to(clip.device), caption, photo_on)
    score1 = clip_similarity(clip, rendered.to(clip.device), caption, photo_on)
    report["metrics"]["clip_similarity"] = score1
    if clip.weights == "random":  # the one place the user is told
        from inkmotion.clip.model import RANDOM_WARNING

        report["warnings"] = [RANDOM_WARNING, *(report.get("warnings") or [])]
    report.update(varying_width=bool(p.varying_width), clip_model=clip.name,
                  clip_weights=clip.weights, clip_similarity_initial=score0,
                  clip_similarity_final=score1,
                  provenance={"clip_weights": clip.weights, "clip_model": clip.name})
    return report
