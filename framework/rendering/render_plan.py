"""Re-render a saved plan at any size (``inkmotion render``): the 'raster' pen line or the
spray preview, in a paint colour on a paper colour, written as an RGB PNG atomically.

The plan's canvas is scaled so its longer side is ``size`` px; the raster's stroke width
scales with it (a 3-px pen on a 350-px canvas is 34 px wide at 4000 px), so a print shows
what the preview shows. Raster coverage c gives the colour paper·(1 − c) + paint·c.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inkmotion.errors import InputError

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import Renderer

#: the largest output side, px (4000 px prints are the target; this bounds the memory)
MAX_SIZE = 16384


def parse_colour(text: str, what: str) -> tuple[float, float, float]:
    """'#rrggbb', 'rrggbb' or one of the names black, white, red, blue as RGB in [0, 1];
    an InputError naming ``what`` otherwise."""
    names = {"black": "000000", "white": "ffffff", "red": "d62728", "blue": "1f3fbf"}
    value = names.get(text.lower(), text.lstrip("#"))
    if len(value) != 6 or any(c not in "0123456789abcdefABCDEF" for c in value):
        raise InputError(f"{what} {text!r} is not a colour; give #rrggbb, e.g. #1a1a1a, or "
                         "black, white, red, blue.")
    return tuple(int(value[i:i + 2], 16) / 255.0 for i in (0, 2, 4))  # type: ignore[return-value]


#: the most pixel evaluations (pieces × the pixels around each) of one renderer call:
#: a large print is drawn in batches of segments, each its own call, bounding the memory
#: (the image is the per-pixel maximum of the batches' images: the same image)
BATCH_PIXELS = 20_000_000


def raster_image(drawing: object, renderer: Renderer, size: int,
                 colour: tuple[float, float, float],
                 paper: tuple[float, float, float]) -> np.ndarray:
    """RGB (H, W, 3) uint8 of the plan drawn by ``renderer`` (the 'raster' plugin) at
    ``size`` px, in batches of segments of at most :data:`BATCH_PIXELS` evaluations."""
    import torch

    from inkmotion.rendering.drawing import plan_segments
    from inkmotion.rendering.raster import PIECE_LENGTH, piece_counts

    canvas = drawing.canvas  # type: ignore[attr-defined]
    scale = size / max(float(canvas[0]), float(canvas[1]))
    width, height = max(1, round(canvas[0] * scale)), max(1, round(canvas[1] * scale))
    segments, widths = plan_segments(drawing.plans, scale,  # type: ignore[attr-defined]
                                     torch.float32)
    with torch.no_grad():
        reach = (segments[..., 2].amax(1) if segments.shape[-1] == 3 else widths / 2) + 2
        cost = piece_counts(segments, reach, height, width) * (PIECE_LENGTH + 2 * reach) ** 2
        batch = torch.cumsum(cost, 0) // BATCH_PIXELS  # (S,) each segment's batch
        coverage = torch.zeros(height, width)
        for k in torch.unique(batch).tolist():
            mine = batch == k
            coverage = torch.maximum(coverage, renderer(segments[mine], widths[mine], height,
                                                        width))
    c = coverage.numpy()
    rgb = np.empty((*c.shape, 3), np.uint8)  # a channel at a time: a print is 10⁸ pixels
    for k in range(3):
        rgb[..., k] = np.clip(np.round(255.0 * (paper[k] + (colour[k] - paper[k]) * c)),
                              0, 255)
    return rgb


def check_options(renderer: str, size: int, colour: str, background: str
                  ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The paint and paper colours (RGB in [0, 1]) of :func:`render_plan`'s options, or an
    InputError naming the option that is wrong. Imports nothing heavy: ``inkmotion render``
    refuses a bad option before torch is loaded (under a second, not three)."""
    if renderer not in ("raster", "spray"):
        raise InputError(f"--renderer {renderer!r}: render draws with raster or spray.")
    if not 8 <= size <= MAX_SIZE:
        raise InputError(f"--size {size} must be between 8 and {MAX_SIZE} px.")
    return parse_colour(colour, "--colour"), parse_colour(background, "--background")


def render_plan(plan_path: str | Path, out: str | Path, *, renderer: str = "raster",
                raster: Renderer | None = None, size: int = 1000, seed: int = 0,
                colour: str = "#141418", background: str = "#ffffff") -> dict:
    """Render ``plan_path`` into the PNG ``out``; returns the figures (size, drips, ...).
    ``renderer`` 'raster' draws with ``raster`` (the caller's 'raster' renderer plugin).
    The options are checked first (:func:`check_options`)."""
    from inkmotion.rendering.spray_preview import SprayStyle, spray_preview
    from inkmotion.sigma_lognormal import Drawing

    ink, paper = check_options(renderer, size, colour, background)
    drawing = Drawing.load(plan_path)
    figures: dict = {"renderer": renderer, "size": size}
    if renderer == "spray":
        preview = spray_preview(drawing, size, seed, SprayStyle(colour=ink, paper=paper))
        rgb = preview.rgb
        figures.update(seed=seed, drips=len(preview.drips))
    else:
        assert raster is not None, "render_plan: the raster renderer is needed"
        rgb = raster_image(drawing, raster, size, ink, paper)
    write_rgb_png(Path(out), rgb)
    figures.update(width=int(rgb.shape[1]), height=int(rgb.shape[0]))
    return figures


def write_rgb_png(path: Path, rgb: np.ndarray) -> None:
    """An RGB (H, W, 3) uint8 image as a PNG, written atomically (its folder made when
    missing, as a run's --out is)."""
    import cv2

    from inkmotion.outputs.atomic import write_bytes_atomic

    ok, data = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    assert ok, "OpenCV could not encode the PNG"
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(path, data.tobytes())


def write_spray_png(path: Path, drawing: object, seed: int) -> int:
    """spray.png of a job: the spray preview at twice the canvas size; returns the drips."""
    from inkmotion.rendering.spray_preview import spray_preview

    canvas = drawing.canvas  # type: ignore[attr-defined]
    preview = spray_preview(drawing, 2 * round(max(canvas)), seed)
    write_rgb_png(path, preview.rgb)
    return len(preview.drips)
