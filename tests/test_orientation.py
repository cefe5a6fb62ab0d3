"""A picture stored turned or mirrored, with the EXIF orientation tag saying how to show it
(a phone's portrait photo), is read upright by both readers: the tracer's
(:func:`inkmotion.tracing.read_picture`) and the photo reader of the generation kinds
(:func:`inkmotion.images.load.read_rgb`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageOps

from inkmotion.images.load import read_rgb
from inkmotion.images.orientation import exif_orientation, upright


def _tagged(path: Path, pixels: np.ndarray, orientation: int) -> Path:
    exif = Image.Exif()
    exif[0x0112] = orientation
    Image.fromarray(pixels).save(path, exif=exif)
    return path


@pytest.mark.parametrize("orientation", range(1, 9))
@pytest.mark.parametrize("channels", [0, 3])
def test_upright_turns_the_pixels_as_pillow_shows_them(tmp_path: Path, orientation: int,
                                                       channels: int) -> None:
    rng = np.random.default_rng(orientation)
    shape = (5, 7, channels) if channels else (5, 7)
    stored = rng.integers(0, 255, shape, dtype=np.uint8)
    path = _tagged(tmp_path / "p.png", stored, orientation)
    with Image.open(path) as img:
        shown = np.asarray(ImageOps.exif_transpose(img))
    assert exif_orientation(path.read_bytes()) == orientation
    assert np.array_equal(upright(stored, orientation), shown)


def test_a_phone_photo_is_read_upright(tmp_path: Path) -> None:
    """A portrait photo stored as landscape pixels and tag 6 reads as the portrait."""
    portrait = np.zeros((60, 40, 3), np.uint8)
    portrait[:10] = (255, 0, 0)  # a red sky at the top
    portrait[10:] = (0, 0, 255)
    stored = np.asarray(Image.fromarray(portrait).transpose(Image.Transpose.ROTATE_90))
    rgb = read_rgb(_tagged(tmp_path / "photo.png", stored, 6))
    assert rgb.shape == (60, 40, 3)
    assert np.allclose(rgb[:10], (1, 0, 0)) and np.allclose(rgb[10:], (0, 0, 1))


def test_a_picture_without_exif_is_read_as_stored(tmp_path: Path) -> None:
    pixels = np.arange(35, dtype=np.uint8).reshape(5, 7)
    path = tmp_path / "plain.png"
    Image.fromarray(pixels).save(path)
    assert exif_orientation(path.read_bytes()) == 1
    assert np.array_equal(read_rgb(path)[..., 0] * 255, pixels.astype(np.float32))
    assert exif_orientation(b"not a picture") == 1


def test_a_large_phone_photo_is_reduced_and_turned_with_one_scale(tmp_path: Path) -> None:
    """A portrait photo over the tracer's pixel budget, stored turned: it is reduced as it
    is decoded and turned upright, and its scale is the shown width's (not the stored)."""
    from inkmotion.tracing import read_picture
    from inkmotion.tracing.picture import WORK_PIXELS

    h = int((2 * WORK_PIXELS / 0.48) ** 0.5)  # stored landscape: w = 2h + 1 (odd)
    stored = np.full((h, 2 * h + 1), 235, np.uint8)
    stored[h // 2 - 10:h // 2 + 10, 100:-100] = 20  # a bar along the stored width
    path = _tagged(tmp_path / "big.jpg", stored, 6)
    picture = read_picture(str(path))
    shown_h, shown_w = picture.grey.shape
    assert shown_h > shown_w  # upright: the bar now runs down the page
    assert abs(picture.scale - shown_w / h) < 1e-9 and picture.scale < 1
