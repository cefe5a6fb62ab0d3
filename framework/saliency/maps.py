"""What every saliency estimator shares: checking the input image, smoothing and normalising.

A saliency map here is an (H, W) tensor in [0, 1] on the image's device and dtype. Raw maps
(a spectral residual, |∂ similarity / ∂ pixel|, a class probability) are noisy and on
arbitrary scales, so each estimator ends with :func:`smooth_and_normalise`: a Gaussian blur
whose σ is a fraction of the image's longer side (the same look at every resolution), then
min-max normalisation m ← (m − min m) / (max m − min m); a constant map becomes all zeros.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F

from inkmotion.errors import InputError

#: default blur σ as a fraction of the longer image side (≈ 5 px on a 512-px image)
DEFAULT_BLUR = 0.01


def as_rgb(image: torch.Tensor, what: str = "saliency input") -> torch.Tensor:
    """``image`` as (3, H, W): a grey (H, W) or (1, H, W) image is repeated on three channels.

    Raises :class:`~inkmotion.errors.InputError` for any other shape or an empty image.
    """
    if image.ndim == 2:
        image = image.unsqueeze(0)
    if image.ndim != 3 or image.shape[0] not in (1, 3) or min(image.shape[1:]) < 1:
        raise InputError(f"The {what} must be an (H, W) or (3, H, W) image tensor, not "
                         f"{tuple(image.shape)}; pass an RGB image in [0, 1].")
    return image.expand(3, -1, -1) if image.shape[0] == 1 else image


def gaussian_blur(x: torch.Tensor, sigma: float) -> torch.Tensor:
    """Separable Gaussian blur of x (H, W) with σ px (kernel ±3σ, reflect padding where the
    image is large enough, replicate otherwise); σ ≤ 0 returns x."""
    if sigma <= 0:
        return x
    r = max(1, math.ceil(3 * sigma))
    t = torch.arange(-r, r + 1, dtype=x.dtype, device=x.device)
    k = torch.exp(-0.5 * (t / sigma) ** 2)
    k = k / k.sum()  # (2r+1,)
    h, w = x.shape
    y = x.reshape(1, 1, h, w)
    mode_w = "reflect" if w > r else "replicate"
    mode_h = "reflect" if h > r else "replicate"
    y = F.conv2d(F.pad(y, (r, r, 0, 0), mode=mode_w), k.view(1, 1, 1, -1))
    y = F.conv2d(F.pad(y, (0, 0, r, r), mode=mode_h), k.view(1, 1, -1, 1))
    return y.reshape(h, w)


def normalise(x: torch.Tensor) -> torch.Tensor:
    """Min-max normalisation of x to [0, 1]; a constant (or all non-finite) map gives zeros."""
    x = torch.nan_to_num(x, nan=0.0, posinf=0.0, neginf=0.0)
    lo, hi = x.min(), x.max()
    span = hi - lo
    return torch.where(span > 0, (x - lo) / torch.where(span > 0, span, 1.0), 0.0).clamp(0, 1)


def smooth_and_normalise(raw: torch.Tensor, blur: float = DEFAULT_BLUR) -> torch.Tensor:
    """Blur a raw map (H, W) with σ = ``blur`` × max(H, W) px, then normalise to [0, 1]."""
    return normalise(gaussian_blur(raw, blur * max(raw.shape)))
