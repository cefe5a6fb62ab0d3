"""Saliency "clip": CLIP relevancy, the gradient of CLIP's similarity w.r.t. the pixels.

With a caption: mean over random augmentations of |∂ cos(f_I(x), f_T(caption)) / ∂x|, summed
over channels; without one: integrated gradients of the similarity to the image's own
embedding (the plain gradient vanishes at that maximum). Blurred and normalised to [0, 1].
See :mod:`inkmotion.saliency.clip_relevancy`. The model is the job's (``reference.extra
["clip"]``) or is loaded from the ``model``, ``pretrained`` and ``weights`` keywords.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.clip.weights import AUTO, DEFAULT_MODEL, DEFAULT_PRETRAINED
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    import torch

    from inkmotion.plugin_host.protocols import Reference, Saliency


@dataclass
class ClipSaliencyOptions:
    """Options of the 'clip' saliency.

    The model is not an option: a job shares its own CLIP (``--clip-model``,
    ``--clip-pretrained``, ``--clip-weights`` of the generation kinds, which would also be
    the flags of options named model, pretrained and weights here). Called directly with no
    shared model, the plugin takes ``model``, ``pretrained`` and ``weights`` keywords.
    """

    samples: int = param(8, "Random augmentations averaged.", minimum=1, maximum=256)
    blur: float = param(0.02, "Gaussian blur σ as a fraction of the longer image side.",
                        minimum=0, maximum=0.5)
    seed: int = param(0, "Seed of the augmentations.", minimum=0)


class ClipSaliency:
    """CLIP relevancy saliency."""

    name = "clip"
    description = ("CLIP relevancy: |gradient| of the image-caption similarity w.r.t. the "
                   "pixels (integrated gradients to the image's own embedding without a "
                   "caption), averaged over augmentations, blurred, normalised to [0, 1].")
    Options = ClipSaliencyOptions

    def __call__(self, image: torch.Tensor, reference: Reference | None = None, *,
                 model: str = DEFAULT_MODEL, pretrained: str = DEFAULT_PRETRAINED,
                 weights: str = AUTO, samples: int = 8, blur: float = 0.02,
                 seed: int = 0) -> torch.Tensor:
        """(H, W) map in [0, 1] of ``image`` (3, H, W) RGB in [0, 1], with the job's CLIP
        (``reference.extra["clip"]``) or else ``load_clip(model, pretrained, weights)``."""
        from inkmotion.saliency.clip_relevancy import clip_relevancy

        extra: dict[str, Any] = getattr(reference, "extra", None) or {}
        clip = extra.get("clip")
        if clip is None:
            from inkmotion.clip.model import load_clip

            clip = load_clip(model, pretrained, weights, image.device)
        caption = getattr(reference, "caption", None)
        return clip_relevancy(image, clip, caption, samples=samples, blur=blur, seed=seed)


@hookimpl
def inkmotion_saliency() -> list[Saliency]:
    return [ClipSaliency()]
