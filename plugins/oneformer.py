"""Saliency "oneformer": the paper's saliency from OneFormer panoptic segmentation (COCO).

Per-pixel probability of a COCO *thing* segment from OneFormer's last-layer query
activations (MaskFormer semantic inference summed over the thing classes), blurred and
normalised; see :mod:`inkmotion.saliency.oneformer`. Optional: needs the ``transformers``
package and the model's weights on disk (nothing is downloaded); without them it refuses
with one sentence saying what to install, or to use the weight-free 'spectral' saliency.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    import torch

    from inkmotion.plugin_host.protocols import Reference, Saliency

DEFAULT_MODEL_ID = "shi-labs/oneformer_coco_swin_large"


@dataclass
class OneformerOptions:
    """Options of the 'oneformer' saliency."""

    model: str = param(DEFAULT_MODEL_ID, "Hugging Face model id (or local folder) of a "
                       "COCO-panoptic OneFormer, already downloaded.")
    blur: float = param(0.01, "Gaussian blur σ as a fraction of the longer image side.",
                        minimum=0, maximum=0.5)


class OneformerSaliency:
    """The paper's OneFormer (COCO panoptic) saliency."""

    name = "oneformer"
    description = ("The paper's saliency: per-pixel probability of a COCO thing segment from "
                   "OneFormer's panoptic queries (optional: needs transformers and local "
                   "weights).")
    Options = OneformerOptions

    def __call__(self, image: torch.Tensor, reference: Reference | None = None, *,
                 model: str = DEFAULT_MODEL_ID, blur: float = 0.01) -> torch.Tensor:
        """(H, W) map in [0, 1] of ``image`` (3, H, W) RGB in [0, 1]; ``reference`` unused."""
        from inkmotion.saliency.oneformer import oneformer_saliency

        return oneformer_saliency(image, model, blur)


@hookimpl
def inkmotion_saliency() -> list[Saliency]:
    return [OneformerSaliency()]
