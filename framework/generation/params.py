"""Parameters shared by the generative job kinds ('tag', 'abstract'): the optimisation, the
stroke (fixed or varying width), and the CLIP model with its weights.

Defaults follow the paper's CLIP applications (ClipDraw / CLIPasso settings at a 224-px
canvas, the CLIP input size) where it gives them; the rest are ours and say why. No torch is
imported here: the command line builds its options from these dataclasses.
"""

from __future__ import annotations

from dataclasses import dataclass

from inkmotion.clip.weights import DEFAULT_MODEL as DEFAULT_CLIP_MODEL
from inkmotion.clip.weights import DEFAULT_PRETRAINED as DEFAULT_CLIP_PRETRAINED
from inkmotion.errors import SpecError
from inkmotion.jobs.params import PluginChoice, param, plugin_param


@dataclass
class GenerationParams:
    """What every CLIP-driven job shares; each kind adds its inputs and overrides defaults."""

    steps: int = param(300, "Adam steps.", minimum=1, maximum=100_000)
    size: int = param(224, "Canvas longer side, px (CLIP sees 224 px).", minimum=32,
                      maximum=4096)
    targets: int = param(30, "Number of virtual targets (sub-movements) to start from.",
                         minimum=1, maximum=5000)
    width: float = param(4.0, "Stroke width, px (the start width with --varying-width).",
                         minimum=0.1, maximum=256)
    varying_width: bool = param(False, "Optimise the stroke radius along the path (2.5D).")
    radius_min: float = param(0.5, "Smallest stroke radius, px, with --varying-width.",
                              minimum=0)
    radius_max: float = param(4.0, "Largest stroke radius, px, with --varying-width.",
                              minimum=0)
    lr_radius: float = param(0.1, "Learning rate of the stroke radius, px.", minimum=0)
    lambda_smooth: float = param(1.0, "Weight λ of the smoothing (minimum-time) cost.",
                                 minimum=0, flag="--lambda")
    w_image: float = param(10.0, "Weight of the image (CLIP) loss.", minimum=0)
    w_sigma: float = param(50.0, "Weight of Var(Δt) in the smoothing cost.", minimum=0)
    w_canvas: float = param(1.0, "Weight of the term keeping targets on the canvas.",
                            minimum=0)
    lr_points: float = param(1.0, "Learning rate of the virtual targets, px.", minimum=0)
    lr_delta_t: float = param(0.05, "Learning rate of the overlaps Δt.", minimum=0)
    lr_delta: float = param(0.1, "Learning rate of the turning angles δ.", minimum=0)
    lr_ac: float = param(0.0, "Learning rate of the shapes Ac (0 keeps them fixed).",
                         minimum=0)
    lr_final: float = param(0.1, "Cosine decay of the learning rates to this fraction.",
                            minimum=0, maximum=1)
    samples_per_move: int = param(5, "Bézier segments per lognormal on the fitting grid.",
                                  minimum=1, maximum=100)
    clip_model: str = param(DEFAULT_CLIP_MODEL,
                            "open_clip model name, or an open_clip model-config JSON file.")
    clip_pretrained: str = param(DEFAULT_CLIP_PRETRAINED,
                                 "open_clip pretrained tag of the model's weights.")
    clip_weights: str = param(
        "auto", "Weights: auto (open_clip's cache), a checkpoint file, or random (tests only).")
    renderer: PluginChoice = plugin_param("renderer", "raster", "Renderer plugin.")
    spray_preview: bool = param(False, "Also write spray.png, the spray-paint preview of "
                                "the result (seeded by the job's seed).")

    def validate(self) -> None:
        if self.varying_width and self.radius_min > self.radius_max:
            raise SpecError(f"--radius-min {self.radius_min} is above --radius-max "
                            f"{self.radius_max}; swap them.")
        if not self.clip_weights.strip():
            raise SpecError("--clip-weights is empty; give auto, a checkpoint file or random.")
        check_one_clip(self)


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
