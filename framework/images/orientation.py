"""A picture's EXIF orientation: a phone stores a portrait photo as landscape pixels and a
tag saying how to turn them; every viewer shows it upright, and so do the readers of
pictures (:mod:`inkmotion.tracing.picture`) and photos (:mod:`inkmotion.images.load`).
Pillow reads the tag; the turn is applied to the decoded array (no torch here: the tracer
imports this).
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: the EXIF tag of a picture's orientation (1: as stored, 2–8: mirrored and/or turned)
ORIENTATION_TAG = 0x0112


def exif_orientation(data: bytes | memoryview) -> int:
    """The EXIF orientation (1–8) that the picture file's bytes ``data`` declare, 1 when
    they declare none, read by Pillow from the header alone."""
    import io

    from PIL import Image

    try:
        with Image.open(io.BytesIO(data)) as img:
            return orientation_of(img)
    except Exception:  # noqa: BLE001 - no readable header: the decoder will say so
        return 1


def orientation_of(img: Any) -> int:
    """The EXIF orientation (1–8) of an opened Pillow image, 1 for none or an invalid one."""
    try:
        value = img.getexif().get(ORIENTATION_TAG, 1)
    except Exception:  # noqa: BLE001 - a damaged EXIF block is no orientation
        return 1
    return value if isinstance(value, int) and 1 <= value <= 8 else 1


def upright(pixels: np.ndarray, orientation: int) -> np.ndarray:
    """``pixels`` (H, W[, C]) as stored, turned the way EXIF ``orientation`` says to show
    them (as Pillow's ``ImageOps.exif_transpose`` does): 2 mirror, 3 half turn, 4 flip, 5
    transpose, 6 quarter turn clockwise, 7 transverse, 8 quarter turn anticlockwise."""
    if orientation == 2:
        return pixels[:, ::-1]
    if orientation == 3:
        return pixels[::-1, ::-1]
    if orientation == 4:
        return pixels[::-1]
    if orientation == 5:
        return np.swapaxes(pixels, 0, 1)
    if orientation == 6:
        return np.swapaxes(pixels, 0, 1)[:, ::-1]
    if orientation == 7:
        return np.swapaxes(pixels, 0, 1)[::-1, ::-1]
    if orientation == 8:
        return np.swapaxes(pixels, 0, 1)[::-1]
    return pixels
