"""Weight-free saliency from OpenCV contrib (``cv2.saliency``): no model, no download.

Two static estimators:

- ``spectral-residual`` (Hou & Zhang, CVPR 2007). On a grey image resized to r × r the
  log amplitude spectrum L(f) = log |F[I](f)| minus its 3×3 local mean is the "spectral
  residual" R(f) = L(f) − h₃ * L(f); the map is S = g * |F⁻¹[exp(R(f) + i·P(f))]|² (P the
  phase), resized back to the image. What stands out of the image's average 1/f spectrum
  (objects, not textures or gradients) lights up. OpenCV's default r is 64; ``resolution``
  sets it.
- ``fine-grained`` (Montabone & Soto 2010): centre–surround differences of box-filtered
  intensity at several scales, at full resolution — in effect a multi-scale edge and
  contrast map.

Both raw maps are then blurred (σ = ``blur`` × longer side) and normalised to [0, 1]
(:func:`inkmotion.saliency.maps.smooth_and_normalise`).

Default: fine-grained. The choice was made on what the map is for — weighted Voronoi
stippling with density saliency² (the 'voronoi-tsp' initialiser, 150 points) — by drawing
the stipples and tours of both maps over skimage's astronaut, chelsea (cat) and coffee.
Fine-grained spreads the points along the subject's structure: the face, eyes and hair,
the collar, the shuttle, the cat's eyes, nose and ears, the cup's rim and the spoon.
Spectral residual's response is peaky: it crowds the points onto a few small high-contrast
spots (the helmet's reflection, the badge, the spoon) — 26 % (astronaut) and 29 % (coffee)
of its tour's sub-movements are shorter than 15 px, against 0 % for fine-grained (median
21 vs 33 px on the astronaut) — covers the face and the shuttle sparsely, and lines the
cat image's top border with points (likely the FFT's periodic wrap-around). Its raw map
looks cleaner (the background stays dark where fine-grained is grey), but squaring the
saliency removes fine-grained's grey floor. Spectral residual at r = 128 rather than
OpenCV's 64 when chosen: 64 px is too coarse for a face at 512 px.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from inkmotion.errors import PluginError
from inkmotion.saliency.maps import DEFAULT_BLUR, as_rgb, smooth_and_normalise

METHODS = ("fine-grained", "spectral-residual")
DEFAULT_METHOD = "fine-grained"
#: side of the square the spectral residual is computed on (Hou & Zhang use 64)
DEFAULT_RESOLUTION = 128


def _cv2_saliency() -> Any:
    """OpenCV's saliency module, or a :class:`PluginError` saying what to install."""
    try:
        import cv2
    except ImportError as err:  # pragma: no cover - cv2 is a dependency
        raise PluginError("The spectral saliency needs OpenCV; install "
                          "opencv-contrib-python-headless.") from err
    module = getattr(cv2, "saliency", None)
    if module is None:
        raise PluginError("The spectral saliency needs OpenCV's contrib module cv2.saliency, "
                          "which this OpenCV lacks; install opencv-contrib-python-headless "
                          "(and uninstall opencv-python-headless).")
    return module


def raw_spectral_saliency(rgb: np.ndarray, method: str = DEFAULT_METHOD,
                          resolution: int = DEFAULT_RESOLUTION) -> np.ndarray:
    """The raw OpenCV map (H, W) float32 of an RGB image ``rgb`` (H, W, 3) uint8."""
    saliency = _cv2_saliency()
    if method == "spectral-residual":
        estimator = saliency.StaticSaliencySpectralResidual_create()
        estimator.setImageWidth(int(resolution))
        estimator.setImageHeight(int(resolution))
    elif method == "fine-grained":
        estimator = saliency.StaticSaliencyFineGrained_create()
    else:
        raise ValueError(f"unknown method {method!r}; one of {METHODS}")
    ok, raw = estimator.computeSaliency(np.ascontiguousarray(rgb[:, :, ::-1]))  # OpenCV: BGR
    assert ok and raw.shape == rgb.shape[:2], (ok, raw.shape, rgb.shape)
    return raw.astype(np.float32)


def spectral_saliency(image: torch.Tensor, method: str = DEFAULT_METHOD,
                      resolution: int = DEFAULT_RESOLUTION,
                      blur: float = DEFAULT_BLUR) -> torch.Tensor:
    """Saliency (H, W) in [0, 1] of ``image`` (3, H, W) or (H, W) in [0, 1], on the image's
    device and dtype (the OpenCV part runs on the CPU)."""
    rgb = as_rgb(image)
    u8 = (rgb.detach().float().clamp(0, 1) * 255).round().to(torch.uint8)
    raw = raw_spectral_saliency(u8.permute(1, 2, 0).cpu().numpy(), method, resolution)
    dtype = image.dtype if image.is_floating_point() else torch.float32
    return smooth_and_normalise(torch.from_numpy(raw).to(device=image.device, dtype=dtype),
                                blur)
