"""Image loss "clip-visual": CLIPasso's perceptual loss (paper eq. "clip2").

    L = Σ_l λ_l · mean( (CLIP_l(aug(target)) − CLIP_l(aug(I)))² )

over intermediate layers l of CLIP's visual encoder (CLIPasso's index: the output of
``visual.transformer.resblocks[l]``, counted from 0; default λ2 = λ3 = 0.5, λ6 = 1), the
same random augmentations applied to the target image and the rendering I each step. The
implementation lives in :mod:`inkmotion.clip.losses`; this module is the plugin's
registration only and imports no torch, so listing plugins stays fast.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.clip.weights import DEFAULT_MODEL, DEFAULT_PRETRAINED
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    import torch

    from inkmotion.plugin_host.protocols import ImageLoss

DEFAULT_LAYERS = "2:0.5,3:0.5,6:1.0"


@dataclass
class ClipVisualOptions:
    """Options of the 'clip-visual' image loss."""

    layers: str = param(DEFAULT_LAYERS, "Visual layers and weights 'l:λ,l:λ'; l is CLIPasso's "
                        "index: the output of resblocks[l], from 0.")
    augmentations: int = param(4, "Random augmentations per step (n).", minimum=1,
                               maximum=256)
    perspective: float = param(0.5, "Perspective distortion scale of the augmentations.",
                               minimum=0, maximum=1)
    crop_min: float = param(0.7, "Smallest resized-crop area fraction.", minimum=0.01,
                            maximum=1)
    crop_max: float = param(0.9, "Largest resized-crop area fraction.", minimum=0.01,
                            maximum=1)
    model: str = param(DEFAULT_MODEL, "open_clip model name, or an open_clip model-config "
                       "JSON file.")
    pretrained: str = param(DEFAULT_PRETRAINED, "open_clip pretrained tag of the weights.")
    weights: str = param("auto", "'auto' (open_clip's cache, no download), a local "
                         "checkpoint file, or 'random' (tests only).")


class ClipVisual:
    """Weighted squared distance of intermediate CLIP activations, target vs. rendering."""

    name = "clip-visual"
    description = (
        "CLIPasso perceptual loss (paper eq. clip2): Σ_l λ_l · mean squared difference of "
        "CLIP visual activations at layer l, same augmentations on target and drawing."
    )
    Options = ClipVisualOptions

    def prepare(self, reference: Any, **options: Any) -> Callable[[torch.Tensor], torch.Tensor]:
        """``loss(rendered (H, W)) -> 0-d tensor`` against ``reference.image``."""
        from inkmotion.clip.losses import prepare_clip_visual

        return prepare_clip_visual(reference, **options)


@hookimpl
def inkmotion_image_losses() -> list[ImageLoss]:
    return [ClipVisual()]
