"""Saliency "spectral": weight-free OpenCV saliency, the offline default.

OpenCV's fine-grained centre–surround map (Montabone & Soto 2010, the default) or the
spectral residual (Hou & Zhang 2007) at 128 × 128, then a Gaussian blur and [0, 1]
normalisation; see :mod:`inkmotion.saliency.spectral` for the methods and why fine-grained
is the default (it spreads TSP-art stipples along the subject's structure). Needs no
weights and no network; needs ``cv2.saliency`` (opencv-contrib-python-headless).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    import torch

    from inkmotion.plugin_host.protocols import Reference, Saliency


@dataclass
class SpectralOptions:
    """Options of the 'spectral' saliency."""

    method: str = param("fine-grained", "OpenCV static saliency estimator.",
                        choices=("fine-grained", "spectral-residual"))
    resolution: int = param(128, "Side of the square the spectral residual is computed on, px.",
                            minimum=16, maximum=1024)
    blur: float = param(0.01, "Gaussian blur σ as a fraction of the longer image side.",
                        minimum=0, maximum=0.5)


class SpectralSaliency:
    """Weight-free saliency from cv2.saliency."""

    name = "spectral"
    description = ("Weight-free OpenCV saliency: fine-grained centre-surround (default) or "
                   "spectral residual (Hou & Zhang 2007); blurred and normalised to [0, 1].")
    Options = SpectralOptions

    def __call__(self, image: torch.Tensor, reference: Reference | None = None,
                 **options: Any) -> torch.Tensor:
        """(H, W) map in [0, 1] of ``image`` (3, H, W) RGB in [0, 1]; ``reference`` unused."""
        from inkmotion.saliency.spectral import spectral_saliency

        return spectral_saliency(image, **options)


@hookimpl
def inkmotion_saliency() -> list[Saliency]:
    return [SpectralSaliency()]
