"""PNG images: the rendering (ink black on white) and an overlay of target and result.

Overlay colours (RGB): the target's ink is light red (255, 150, 150), the result's ink
is dark blue (20, 40, 170) drawn over it with 80 % opacity, so target alone shows red,
result alone blue, and both dark violet. Input traces are drawn as thin red lines and
virtual targets as small orange dots with a dark rim.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import torch

TARGET_RGB = (255, 150, 150)
RESULT_RGB = (20, 40, 170)
RESULT_OPACITY = 0.8
TRACE_RGB = (200, 30, 30)
DOT_RGB = (255, 140, 0)


def _array(image: torch.Tensor | np.ndarray) -> np.ndarray:
    """(H, W) float64 in [0, 1] on the CPU."""
    if isinstance(image, torch.Tensor):
        image = image.detach().to("cpu", torch.float64).numpy()
    a = np.asarray(image, dtype=np.float64)
    assert a.ndim == 2, a.shape
    return np.clip(np.nan_to_num(a), 0.0, 1.0)


def write_image(path: str | Path, bgr_or_grey: np.ndarray) -> None:
    """Write an 8-bit BGR or grey array to an image file (the suffix picks the format)."""
    if not cv2.imwrite(str(path), bgr_or_grey):
        raise OSError(f"{path}: OpenCV could not write the image (check the folder and suffix).")


def write_png(path: str | Path, image: torch.Tensor | np.ndarray) -> None:
    """Coverage (H, W) in [0, 1] as an 8-bit grey PNG, ink black on white."""
    write_image(path, np.round(255.0 * (1.0 - _array(image))).astype(np.uint8))


def bgr(rgb: tuple[int, int, int]) -> tuple[int, int, int]:
    """OpenCV's channel order of an RGB colour."""
    return (rgb[2], rgb[1], rgb[0])


def write_overlay(
    path: str | Path,
    target: torch.Tensor | np.ndarray,
    rendered: torch.Tensor | np.ndarray,
    traces: list[np.ndarray] | None = None,
    positions: list[np.ndarray] | np.ndarray | torch.Tensor | None = None,
) -> None:
    """Colour composite of ``target`` and ``rendered`` (H, W each, [0, 1]) as a PNG.

    ``traces``: optional input polylines (k, ≥2) in px, drawn as thin lines;
    ``positions``: optional virtual targets, (k, ≥2) or a list of such, drawn as dots.
    """
    t, r = _array(target), _array(rendered)
    assert t.shape == r.shape, (t.shape, r.shape)
    img = np.full(t.shape + (3,), 255.0)
    img = img * (1.0 - t[..., None]) + np.array(bgr(TARGET_RGB), float) * t[..., None]
    a = RESULT_OPACITY * r[..., None]
    img = img * (1.0 - a) + np.array(bgr(RESULT_RGB), float) * a
    out = np.ascontiguousarray(np.round(img).astype(np.uint8))
    shift = 4  # sub-pixel precision for cv2 drawing
    scale = float(1 << shift)
    for poly in traces or []:
        pts = np.round(np.asarray(poly, dtype=np.float64)[:, :2] * scale).astype(np.int32)
        if len(pts) >= 2:
            cv2.polylines(out, [pts], False, bgr(TRACE_RGB), 1, cv2.LINE_AA, shift)
    if positions is not None:
        groups = [positions] if not isinstance(positions, list) else positions
        for g in groups:
            if isinstance(g, torch.Tensor):
                g = g.detach().cpu().double().numpy()
            for x, y in np.asarray(g, dtype=np.float64).reshape(-1, np.shape(g)[-1])[:, :2]:
                c = (int(round(x * scale)), int(round(y * scale)))
                cv2.circle(out, c, int(2.5 * scale), (40, 40, 40), -1, cv2.LINE_AA, shift)
                cv2.circle(out, c, int(1.7 * scale), bgr(DOT_RGB), -1, cv2.LINE_AA, shift)
    write_image(path, out)
