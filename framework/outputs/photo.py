"""PNG images of a generation from a photo: the drawing over the faded photo, and the
saliency map as a colour map over the photo's outline."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import torch

#: how much of the photo shows under a drawing (0: white paper, 1: the photo itself)
PHOTO_OPACITY = 0.35
#: ink colour of the drawing over the photo (RGB)
INK_RGB = (20, 20, 140)
#: colour of the virtual targets' dots (RGB)
DOT_RGB = (220, 40, 40)


def _rgb(photo: torch.Tensor) -> np.ndarray:
    """(3, H, W) in [0, 1] → (H, W, 3) float64."""
    return photo.detach().cpu().double().permute(1, 2, 0).clamp(0, 1).numpy()


def write_on_photo(path: str | Path, photo: torch.Tensor, rendered: torch.Tensor,
                   positions: list[torch.Tensor] | None = None) -> None:
    """The drawing (coverage (H, W)) in ink over the photo (3, H, W) faded to
    ``PHOTO_OPACITY`` on white; ``positions``: virtual targets (k, ≥2) drawn as dots."""
    base = 1.0 - PHOTO_OPACITY * (1.0 - _rgb(photo))  # faded towards white
    cov = rendered.detach().cpu().double().clamp(0, 1).numpy()[:, :, None]
    ink = np.array(INK_RGB, dtype=np.float64) / 255.0
    img = base * (1.0 - cov) + ink * cov
    out = np.round(255.0 * img[:, :, ::-1]).astype(np.uint8).copy()
    shift = 4
    scale = float(1 << shift)
    for pts in positions or []:
        for x, y in pts.detach().cpu().double().numpy()[:, :2]:
            c = (int(round(x * scale)), int(round(y * scale)))
            cv2.circle(out, c, int(1.6 * scale), DOT_RGB[::-1], -1, cv2.LINE_AA, shift)
    if not cv2.imwrite(str(path), out):
        raise OSError(f"could not write {path}")


def write_saliency(path: str | Path, saliency: torch.Tensor) -> None:
    """A saliency map (H, W) in [0, 1] as a colour-mapped PNG (viridis: dark is ignored,
    yellow draws the eye)."""
    grey = np.round(255.0 * saliency.detach().cpu().double().clamp(0, 1).numpy())
    cv2.imwrite(str(path), cv2.applyColorMap(grey.astype(np.uint8), cv2.COLORMAP_VIRIDIS))
