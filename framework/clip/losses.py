"""The CLIP image losses: 'clip-text' (CLIPDraw, paper eq. "clip") and 'clip-visual'
(CLIPasso, paper eq. "clip2").

The rendering arrives as ink coverage (H, W) in [0, 1] (ink = 1) and is shown to CLIP as
black ink on white paper, RGB = 1 − coverage. Each evaluation draws n fresh random views
(:mod:`inkmotion.clip.augment`) with torch's RNG on the device, so a step makes no host
synchronisation and a seeded job reproduces.

clip-text, with f the L2-normalised CLIP embeddings and c the caption::

    L = −(1/n) Σ_k cos(f(aug_k(I)), f(c))          ∈ [−1, 1]

clip-visual, with CLIP_l the output of visual block l (CLIPasso's index from 0, see
:mod:`inkmotion.clip.model`) and the *same* views of the target Î and the rendering I::

    L = Σ_l λ_l · mean_{k, tokens, channels} (CLIP_l(aug_k(Î)) − CLIP_l(aug_k(I)))²

i.e. the squared L2 norm of eq. clip2 normalised by the number of elements (CLIPasso's
``l2_layers``: ``torch.square(x − y).mean()`` per layer), so λ does not depend on the
number of views or the encoder's width. Default λ2 = λ3 = 0.5, λ6 = 1 (paper).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import torch
import torch.nn.functional as F

from inkmotion.clip.augment import DEFAULT_RATIO, apply_params, sample_params
from inkmotion.clip.model import (
    AUTO,
    DEFAULT_MODEL,
    DEFAULT_PRETRAINED,
    LoadedClip,
    load_clip,
    weights_problem,
)
from inkmotion.errors import SpecError

DEFAULT_LAYERS = "2:0.5,3:0.5,6:1.0"


# --- pure functions -------------------------------------------------------------------------
def coverage_to_rgb(coverage: torch.Tensor) -> torch.Tensor:
    """(…, 3, H, W) black ink on white paper, 1 − coverage, from coverage (…, H, W)."""
    paper = 1 - coverage
    return paper.unsqueeze(-3).expand(*paper.shape[:-2], 3, *paper.shape[-2:])


def as_rgb(image: torch.Tensor, what: str = "image") -> torch.Tensor:
    """(3, H, W) RGB in [0, 1] from coverage (H, W) or RGB (3, H, W) (a (1, H, W) image is
    coverage too); anything else is refused with one sentence naming ``what``."""
    if image.ndim == 2:
        return coverage_to_rgb(image)
    if image.ndim == 3 and image.shape[0] == 1:
        return coverage_to_rgb(image[0])
    if image.ndim == 3 and image.shape[0] == 3:
        return image
    raise SpecError(f"The {what} has shape {tuple(image.shape)}; a CLIP loss needs coverage "
                    "(H, W) or RGB (3, H, W) in [0, 1].")


def parse_layers(text: str, depth: int | None = None) -> dict[int, float]:
    """{l: λ_l} from ``"l:λ,l:λ"`` (e.g. ``"2:0.5,3:0.5,6:1.0"``), zero weights dropped.

    Refuses (SpecError, one sentence) a malformed entry, a repeated or negative layer, a
    negative or non-finite weight, no positive weight, and — given the encoder's ``depth``
    — a layer beyond it.
    """
    out: dict[int, float] = {}
    hint = "write layers as 'l:weight,l:weight', e.g. '2:0.5,3:0.5,6:1.0'"
    for part in str(text).split(","):
        layer_s, sep, weight_s = part.strip().partition(":")
        try:
            layer, weight = int(layer_s), float(weight_s)
        except ValueError:
            layer, weight = -1, float("nan")
        if not sep or layer < 0 or not weight >= 0 or weight == float("inf"):
            raise SpecError(f"The clip-visual layers option {text!r} has a malformed entry "
                            f"{part.strip()!r}; {hint}.")
        if layer in out:
            raise SpecError(f"The clip-visual layers option {text!r} names layer {layer} "
                            f"twice; {hint}.")
        out[layer] = weight
    out = {layer: w for layer, w in out.items() if w > 0}
    if not out:
        raise SpecError(f"The clip-visual layers option {text!r} gives no layer a positive "
                        f"weight; {hint}.")
    if depth is not None and max(out) >= depth:
        raise SpecError(f"The clip-visual layers option {text!r} names layer {max(out)}, but "
                        f"the CLIP image encoder has layers 0..{depth - 1}; choose layers in "
                        "that range.")
    return out


def clip_text_loss(clip: LoadedClip, rgb: torch.Tensor, text: torch.Tensor,
                   params: torch.Tensor) -> torch.Tensor:
    """Eq. clip: −mean_k cos(f(aug_k(rgb)), text) for rgb (3, H, W), text (E,) normalised,
    views ``params`` (n, 3, 3); a 0-d tensor."""
    views = apply_params(rgb, params, clip.image_size)  # (n, 3, S, S)
    return -(clip.encode_image(views) @ text).mean()


def clip_visual_loss(clip: LoadedClip, rgb: torch.Tensor, target: torch.Tensor,
                     layers: dict[int, float], params: torch.Tensor) -> torch.Tensor:
    """Eq. clip2: Σ_l λ_l·mean (CLIP_l(aug(target)) − CLIP_l(aug(rgb)))² with the same views
    ``params`` of rgb and target (3, H, W) each (same size); a 0-d tensor. The target's
    activations are computed without a graph."""
    with torch.no_grad():
        goal = clip.image_activations(apply_params(target, params, clip.image_size), layers)
    acts = clip.image_activations(apply_params(rgb, params, clip.image_size), layers)
    total = acts[next(iter(layers))].new_zeros(())
    for layer, weight in layers.items():
        total = total + weight * (acts[layer] - goal[layer]).square().mean()
    return total


# --- the prepared losses ----------------------------------------------------------------------
@dataclass(frozen=True)
class Views:
    """How many random views per evaluation, and their distortion."""

    n: int = 4
    perspective: float = 0.5
    crop_scale: tuple[float, float] = (0.7, 0.9)
    ratio: tuple[float, float] = DEFAULT_RATIO

    def sample(self, device: torch.device) -> torch.Tensor:
        """(n, 3, 3) fresh views, drawn on ``device``."""
        return sample_params(self.n, perspective=self.perspective, crop_scale=self.crop_scale,
                             ratio=self.ratio, device=device)


def views_from_options(loss: str, augmentations: int, perspective: float, crop_min: float,
                       crop_max: float) -> Views:
    """Checked :class:`Views` from a loss's options (one sentence naming ``loss`` if not)."""
    if int(augmentations) < 1:
        raise SpecError(f"The {loss} option augmentations is {augmentations}; use 1 or more.")
    if not 0 <= perspective <= 1:
        raise SpecError(f"The {loss} option perspective is {perspective}; use a value in "
                        "[0, 1].")
    if not 0 < crop_min <= crop_max <= 1:
        raise SpecError(f"The {loss} options crop_min {crop_min} and crop_max {crop_max} "
                        "must satisfy 0 < crop_min <= crop_max <= 1.")
    return Views(int(augmentations), float(perspective), (float(crop_min), float(crop_max)))


class _Models:
    """The CLIP model of a loss: the job's shared one (``reference.extra["clip"]``) or one
    loaded with the loss's options; on the rendering's device (loaded there, once, when a
    rendering arrives on another device than the first model's)."""

    def __init__(self, reference: Any, loss: str, model: str, pretrained: str,
                 weights: str) -> None:
        extra = getattr(reference, "extra", None) or {}
        self.args = (model, pretrained, weights)
        shared = extra.get("clip")
        if shared is not None:
            self.first: LoadedClip = shared
        else:
            problem = weights_problem(model, pretrained, weights)
            if problem is not None:
                raise SpecError(f"The {loss} image loss cannot load CLIP: {problem}")
            image = getattr(reference, "image", None)
            device = extra.get("device") or (image.device if image is not None else "cpu")
            self.first = load_clip(model, pretrained, weights, device)
        self.shared = shared is not None

    def on(self, device: torch.device) -> LoadedClip:
        """The model on ``device`` (the shared model stays where the job put it)."""
        if self.shared or device == self.first.device:
            return self.first
        return load_clip(*self.args, device)


class ClipTextLoss:
    """``loss(rendered (H, W)) -> 0-d tensor``: eq. clip against a fixed caption."""

    def __init__(self, models: _Models, caption: str, views: Views) -> None:
        self.models = models
        self.caption = caption
        self.views = views
        self._text: dict[torch.device, torch.Tensor] = {}
        self._embed(models.first)  # once, at prepare

    def _embed(self, clip: LoadedClip) -> torch.Tensor:
        if clip.device not in self._text:
            self._text[clip.device] = clip.encode_text([self.caption])[0]  # (E,)
        return self._text[clip.device]

    @property
    def clip(self) -> LoadedClip:
        return self.models.first

    def __call__(self, rendered: torch.Tensor) -> torch.Tensor:
        clip = self.models.on(rendered.device)
        rgb = as_rgb(rendered, "rendering").to(clip.device)
        return clip_text_loss(clip, rgb, self._embed(clip), self.views.sample(clip.device))


class ClipVisualLoss:
    """``loss(rendered (H, W)) -> 0-d tensor``: eq. clip2 against a fixed target image,
    which is resized (bilinear, antialiased) to the rendering's canvas once."""

    def __init__(self, models: _Models, target: torch.Tensor, layers: dict[int, float],
                 views: Views) -> None:
        self.models = models
        self.target = target  # (3, H, W)
        self.layers = layers
        self.views = views
        self._targets: dict[tuple, torch.Tensor] = {}

    @property
    def clip(self) -> LoadedClip:
        return self.models.first

    def _target_like(self, rgb: torch.Tensor) -> torch.Tensor:
        """The target on rgb's device, dtype and canvas size (cached)."""
        key = (rgb.device, rgb.dtype, tuple(rgb.shape[-2:]))
        if key not in self._targets:
            t = self.target.to(device=rgb.device, dtype=rgb.dtype)
            if tuple(t.shape[-2:]) != key[2]:
                t = F.interpolate(t[None], size=key[2], mode="bilinear", antialias=True,
                                  align_corners=False)[0]
            self._targets[key] = t
        return self._targets[key]

    def __call__(self, rendered: torch.Tensor) -> torch.Tensor:
        clip = self.models.on(rendered.device)
        rgb = as_rgb(rendered, "rendering").to(clip.device)
        return clip_visual_loss(clip, rgb, self._target_like(rgb), self.layers,
                                self.views.sample(clip.device))


def prepare_clip_text(reference: Any, *, augmentations: int = 4, perspective: float = 0.5,
                      crop_min: float = 0.7, crop_max: float = 0.9,
                      model: str = DEFAULT_MODEL, pretrained: str = DEFAULT_PRETRAINED,
                      weights: str = AUTO) -> Callable[[torch.Tensor], torch.Tensor]:
    """The 'clip-text' loss bound to ``reference.caption`` (its embedding computed once)."""
    caption = getattr(reference, "caption", None)
    if not caption or not str(caption).strip():
        raise SpecError("The clip-text image loss needs a caption (e.g. 'WORD, a stylish "
                        "graffiti tag') and this job has none; give one, or use clip-visual "
                        "or mse to compare with an image.")
    views = views_from_options("clip-text", augmentations, perspective, crop_min, crop_max)
    models = _Models(reference, "clip-text", model, pretrained, weights)
    return ClipTextLoss(models, str(caption), views)


def prepare_clip_visual(reference: Any, *, layers: str = DEFAULT_LAYERS,
                        augmentations: int = 4, perspective: float = 0.5,
                        crop_min: float = 0.7, crop_max: float = 0.9,
                        model: str = DEFAULT_MODEL, pretrained: str = DEFAULT_PRETRAINED,
                        weights: str = AUTO) -> Callable[[torch.Tensor], torch.Tensor]:
    """The 'clip-visual' loss bound to ``reference.image`` (coverage (H, W) or RGB (3, H, W)
    in [0, 1]); ``layers`` is ``"l:λ,…"`` (CLIPasso's block index from 0)."""
    parse_layers(layers)  # the spelling, before any model is loaded
    image = getattr(reference, "image", reference if torch.is_tensor(reference) else None)
    if image is None:
        raise SpecError("The clip-visual image loss needs a target image and this job has "
                        "only a caption; use clip-text for captions.")
    target = as_rgb(image, "clip-visual target image")
    views = views_from_options("clip-visual", augmentations, perspective, crop_min, crop_max)
    models = _Models(reference, "clip-visual", model, pretrained, weights)
    if models.first.depth == 0:
        raise SpecError(f"The clip-visual image loss needs a vision-transformer CLIP model, "
                        f"and {models.first.name} has no transformer blocks; use e.g. "
                        "ViT-B-32.")
    weights_by_layer = parse_layers(layers, models.first.depth)
    return ClipVisualLoss(models, target, weights_by_layer, views)
