"""Image loss "clip-text": CLIPDraw's caption loss (paper eq. "clip").

    L = −(1/n) Σ_{k=1..n} cos( f_I(aug_k(I)), f_T(caption) )

with n random augmentations (perspective + resized crop) of the rendering I drawn as
black ink on white paper. The implementation lives in :mod:`inkmotion.clip.losses`; this
module is the plugin's registration only and imports no torch, so listing plugins stays
fast.
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



@dataclass
class ClipTextOptions:
    """Options of the 'clip-text' image loss."""

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


class ClipText:
    """Negative mean cosine similarity between augmented renderings and the caption."""

    name = "clip-text"
    description = (
        "CLIPDraw caption loss (paper eq. clip): −mean over n augmentations of "
        "cos(CLIP(aug(drawing)), CLIP(caption))."
    )
    Options = ClipTextOptions

    def prepare(self, reference: Any, **options: Any) -> Callable[[torch.Tensor], torch.Tensor]:
        """``loss(rendered (H, W)) -> 0-d tensor`` against ``reference.caption``."""
        from inkmotion.clip.losses import prepare_clip_text

        return prepare_clip_text(reference, **options)


@hookimpl
def inkmotion_image_losses() -> list[ImageLoss]:
    return [ClipText()]
