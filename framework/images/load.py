"""Read a photo (PNG, JPEG, ... anything OpenCV decodes) into an RGB tensor in [0, 1].

Grey images become three equal channels, 16-bit images are scaled by 1/65535, and an alpha
channel is composited over white paper (a transparent background is paper, not black).
A photo is turned the way its EXIF orientation tag says (a phone stores a portrait photo as
landscape pixels and the tag; every viewer shows it upright, and so is it drawn).
An unreadable, empty or degenerate file is refused with one sentence naming it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from inkmotion.errors import InputError
from inkmotion.images.orientation import exif_orientation, upright

#: longest side accepted before resizing: a bigger image is almost surely a mistake
MAX_SIDE = 20_000
#: the shorter side (px) a photo must keep at the job's size: a thinner strip has no shape
MIN_SHORT_SIDE = 8
#: pixels above which an opaque photo is shrunk in its own bits before it becomes float32
#: (8000 × 6000 = 48 MP takes 2.5 GB the float way; 361 MP took 16 GB)
SHRINK_FIRST_PIXELS = 60_000_000


def read_rgb(path: str | Path, longest: int | None = None) -> np.ndarray:
    """The image at ``path`` as float32 RGB (H, W, 3) in [0, 1], alpha composited on white.
    ``longest``: the caller shrinks it to this longer side anyway, so an opaque image of
    over :data:`SHRINK_FIRST_PIXELS` is first shrunk (area filter) to twice that, in its own
    8 or 16 bits: a 19000² photo took 16 GB as float32 copies before its resize to 224 px.
    (Smaller images take the one resize they always took: their results are unchanged.)"""
    import cv2

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such image file; check the path.")
    data = np.fromfile(path, dtype=np.uint8)
    if data.size == 0:
        raise InputError(f"{path}: the file is empty; give a PNG or JPEG image.")
    raw = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if raw is None or raw.size == 0:
        raise InputError(f"{path}: not an image OpenCV can read; give a PNG or JPEG image.")
    if raw.ndim == 2:
        raw = raw[:, :, None]
    raw = upright(raw, exif_orientation(memoryview(data)))
    h, w, channels = raw.shape
    if min(h, w) < 2 or max(h, w) > MAX_SIDE:
        size = "too small" if min(h, w) < 2 else "too large"
        raise InputError(f"{path}: a {w}×{h} image is {size}; give an image between 2 and "
                         f"{MAX_SIDE} px a side.")
    if (longest is not None and channels in (1, 3) and h * w > SHRINK_FIRST_PIXELS
            and max(h, w) > 2 * longest):
        factor = 2 * longest / max(h, w)
        raw = cv2.resize(raw, (max(1, round(w * factor)), max(1, round(h * factor))),
                         interpolation=cv2.INTER_AREA)
        if raw.ndim == 2:
            raw = raw[:, :, None]
    scale = 65535.0 if raw.dtype == np.uint16 else 255.0 if raw.dtype == np.uint8 else 1.0
    img = raw.astype(np.float32) / scale
    if channels in (1, 2):  # grey (+ alpha)
        rgb, alpha = np.repeat(img[:, :, :1], 3, axis=2), img[:, :, 1:2] if channels == 2 else None
    else:  # OpenCV's BGR(A)
        rgb, alpha = img[:, :, 2::-1], img[:, :, 3:4] if channels == 4 else None
    if alpha is not None:
        rgb = rgb * alpha + (1.0 - alpha)
    rgb = np.clip(np.nan_to_num(rgb, nan=1.0), 0.0, 1.0)
    return np.ascontiguousarray(rgb, dtype=np.float32)


def resize_longer_side(rgb: np.ndarray, size: int) -> np.ndarray:
    """``rgb`` (H, W, 3) resized so its longer side is ``size`` px (area filter when
    shrinking, cubic when enlarging), aspect kept."""
    import cv2

    h, w = rgb.shape[:2]
    scale = size / max(h, w)
    new = (max(1, round(w * scale)), max(1, round(h * scale)))
    if new == (w, h):
        return rgb
    interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_CUBIC
    return np.clip(cv2.resize(rgb, new, interpolation=interp), 0.0, 1.0)


def load_image(path: str | Path, size: int, *, dtype: torch.dtype = torch.float32,
               device: torch.device | str = "cpu") -> torch.Tensor:
    """The image at ``path`` as a (3, H, W) RGB tensor in [0, 1], its longer side ``size``."""
    rgb = resize_longer_side(read_rgb(path, size), size)
    if min(rgb.shape[:2]) < MIN_SHORT_SIDE:
        h, w = rgb.shape[:2]
        raise InputError(f"{path}: a strip this narrow is no picture to draw: at {size} px its "
                         f"shorter side is {min(h, w)} px ({w}×{h}); crop it nearer square "
                         f"(at least {MIN_SHORT_SIDE} px a side at --size {size}).")
    if float(rgb.max() - rgb.min()) < 1e-3:
        raise InputError(f"{path}: the image is blank (a single colour); nothing to draw.")
    return torch.from_numpy(rgb).permute(2, 0, 1).to(dtype=dtype, device=device).contiguous()
