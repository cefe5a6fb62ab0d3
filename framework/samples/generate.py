"""Draw the samples made for the project: ``shapes.png``, ``spiral.svg`` and
``brush-scan.png``.

They were generated once by this module and ship as files; ``python -m
inkmotion.samples.generate DIR`` draws them again into DIR (``tests/test_samples.py``
checks that the shipped files are what it draws). Deterministic: no randomness, no fonts,
no network.

- ``shapes.png``: a still life of three lit solids on a table (a ball, a cylinder and a
  box, each with its shading, highlight and soft shadow, under one light from the upper
  left), photo-like enough for the ``abstract`` kind's saliency and CLIP losses.
- ``spiral.svg``: an Archimedean spiral r = b·θ drawn as cubic Béziers (Hermite
  segments, a quarter turn each), a wave and a loop: three strokes for the ``fit`` kind.
- ``brush-scan.png``: the word "inkmotion" in the Hershey script font written with a
  round brush that is wider on down-strokes (3.5–9 px), on cream paper lit from the
  left, with grain and a soft focus: a picture of line art, as a scan or a phone photo
  gives it, for fits from pictures and ``inkmotion trace``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

#: the still life's size (px), width × height
WIDTH, HEIGHT = 512, 384
#: where the table's top edge meets the wall (px from the top)
HORIZON = 250
#: unit vector towards the light: left, up, towards the viewer (x right, y down, z out)
LIGHT = np.array([-0.55, -0.6, 0.58]) / np.linalg.norm([-0.55, -0.6, 0.58])


def still_life() -> np.ndarray:
    """The still life as an (H, W, 3) uint8 RGB image."""
    import cv2

    y, x = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)  # (H, W) each
    wall = np.array([0.80, 0.76, 0.70]) * (1.0 - 0.25 * (x / WIDTH))[..., None]  # (H, W, 3)
    wall *= (0.9 + 0.1 * (y / HORIZON))[..., None]
    grain = 0.5 + 0.5 * np.sin(0.05 * y + 3.0 * np.sin(0.011 * x))  # wood grain
    table = np.array([0.55, 0.38, 0.24]) * (0.85 + 0.1 * grain)[..., None]
    table *= (0.75 + 0.35 * (y - HORIZON) / (HEIGHT - HORIZON))[..., None]
    image = np.where((y < HORIZON)[..., None], wall, table)

    shadows = np.zeros((HEIGHT, WIDTH), np.float32)
    for centre, axes in (((190, 318), (72, 16)), ((330, 300), (62, 13)), ((445, 290), (52, 12))):
        cv2.ellipse(shadows, centre, axes, 0, 0, 360, 1.0, -1)
    shadows = cv2.GaussianBlur(shadows, (0, 0), 9)
    image *= (1.0 - 0.55 * shadows)[..., None]

    _ball(image, x, y, centre=(150, 250), radius=68, colour=(0.85, 0.35, 0.12))
    _cylinder(image, x, y, left=250, right=350, top=150, bottom=292,
              colour=(0.20, 0.36, 0.68))
    _box(image, left=385, right=470, top=200, bottom=282, depth=(22, -16),
         colour=(0.34, 0.58, 0.30))

    image = cv2.GaussianBlur(image.astype(np.float32), (0, 0), 0.8)  # a lens, not a raster
    return np.clip(255.0 * image, 0, 255).round().astype(np.uint8)


def _lit(normal: np.ndarray, colour: tuple[float, float, float], shine: float) -> np.ndarray:
    """Lambert shading plus a Blinn highlight of unit ``normal`` (..., 3) under
    :data:`LIGHT`, in ``colour``; an ambient term keeps the shadow side visible."""
    diffuse = np.clip(normal @ LIGHT, 0.0, 1.0)[..., None]
    half = (LIGHT + np.array([0.0, 0.0, 1.0])) / np.linalg.norm(LIGHT + [0.0, 0.0, 1.0])
    spec = np.clip(normal @ half, 0.0, 1.0)[..., None] ** shine
    return np.asarray(colour) * (0.25 + 0.75 * diffuse) + 0.6 * spec


def _ball(image: np.ndarray, x: np.ndarray, y: np.ndarray, centre: tuple[int, int],
          radius: int, colour: tuple[float, float, float]) -> None:
    """A shaded sphere painted into ``image`` (H, W, 3) in place."""
    dx, dy = (x - centre[0]) / radius, (y - centre[1]) / radius
    inside = dx**2 + dy**2 < 1.0
    dz = np.sqrt(np.clip(1.0 - dx**2 - dy**2, 0.0, 1.0))
    normal = np.stack([dx, dy, dz], axis=-1)  # (H, W, 3)
    image[inside] = _lit(normal, colour, 40.0)[inside]


def _cylinder(image: np.ndarray, x: np.ndarray, y: np.ndarray, left: int, right: int,
              top: int, bottom: int, colour: tuple[float, float, float]) -> None:
    """An upright shaded cylinder (its top an ellipse seen from slightly above)."""
    cx, r, tilt = 0.5 * (left + right), 0.5 * (right - left), 0.25
    u = (x - cx) / r
    side_n = np.stack([u, np.zeros_like(u), np.sqrt(np.clip(1 - u**2, 0, 1))], axis=-1)
    rim = tilt * r * np.sqrt(np.clip(1 - u**2, 0, 1))
    body = (np.abs(u) < 1) & (y > top) & (y < bottom + rim)
    image[body] = _lit(side_n, colour, 25.0)[body]
    cap = ((x - cx) / r) ** 2 + ((y - top) / (tilt * r)) ** 2 < 1.0
    up = np.broadcast_to(np.array([0.0, -0.9, 0.44]) / np.linalg.norm([0, -0.9, 0.44]),
                         (*x.shape, 3))
    image[cap] = (0.9 * _lit(up, colour, 10.0))[cap]


def _box(image: np.ndarray, left: int, right: int, top: int, bottom: int,
         depth: tuple[int, int], colour: tuple[float, float, float]) -> None:
    """A box: its front, top and side faces, each lit by its own normal."""
    import cv2

    dx, dy = depth
    faces = (
        ([(left, top), (right, top), (right, bottom), (left, bottom)], (0.0, 0.0, 1.0)),
        ([(left, top), (left + dx, top + dy), (right + dx, top + dy), (right, top)],
         (0.0, -1.0, 0.0)),
        ([(right, top), (right + dx, top + dy), (right + dx, bottom + dy), (right, bottom)],
         (1.0, 0.0, 0.0)),
    )
    for corners, normal in faces:
        mask = np.zeros(image.shape[:2], np.uint8)
        cv2.fillConvexPoly(mask, np.array(corners, np.int32), 1)
        n = np.asarray(normal) * 0.8 + np.array([0.0, 0.0, 0.2])
        shade = _lit(n / np.linalg.norm(n), colour, 8.0)  # (3,)
        image[mask.astype(bool)] = shade


def spiral_svg() -> str:
    """The spiral, a wave and a loop as an SVG document (200 × 200 user units)."""
    return "\n".join([
        '<svg xmlns="http://www.w3.org/2000/svg" width="200" height="200" '
        'viewBox="0 0 200 200">',
        "  <title>inkmotion sample: a spiral, a wave and a loop</title>",
        '  <g fill="none" stroke="black" stroke-width="2" stroke-linecap="round">',
        f'    <path id="spiral" d="{_spiral_path((100.0, 80.0), 3.0, 3.2)}"/>',
        '    <path id="wave" d="M 20 178 C 40 158 60 158 80 178 S 120 198 140 178"/>',
        '    <path id="loop" d="M 150 182 C 200 150 170 130 160 160 C 150 190 185 190 190 170"/>',
        "  </g>",
        "</svg>",
        "",
    ])


def _spiral_path(centre: tuple[float, float], turns: float, b: float) -> str:
    """Path data of r = b·θ (θ from 0.3 rad, ``turns`` turns) as cubic Béziers: each quarter
    turn a Hermite segment, control points p ± (Δθ/3)·dp/dθ."""
    cx, cy = centre

    def point(t: float) -> tuple[float, float, float, float]:
        r = b * t
        return (cx + r * math.cos(t), cy + r * math.sin(t),
                b * math.cos(t) - r * math.sin(t), b * math.sin(t) + r * math.cos(t))

    start, step = 0.3, math.pi / 2
    n = round(turns * 4)
    x, y, _, _ = point(start)
    parts = [f"M {x:.2f} {y:.2f}"]
    for k in range(n):
        t0, t1 = start + k * step, start + (k + 1) * step
        x0, y0, dx0, dy0 = point(t0)
        x1, y1, dx1, dy1 = point(t1)
        h = step / 3.0
        parts.append(f"C {x0 + h * dx0:.2f} {y0 + h * dy0:.2f} {x1 - h * dx1:.2f} "
                     f"{y1 - h * dy1:.2f} {x1:.2f} {y1:.2f}")
    return " ".join(parts)


#: the brush scan's word, longer side (px) and seed of its paper grain
SCAN_WORD, SCAN_SIZE, SCAN_SEED = "inkmotion", 900, 7


def brush_scan() -> np.ndarray:
    """``brush-scan.png`` (module docstring) as an (H, W) uint8 grey image."""
    import cv2

    from inkmotion.geometry.chamfer import densify
    from inkmotion.inputs.hershey import render_text

    strokes = render_text(SCAN_WORD).fit_to_canvas(SCAN_SIZE).strokes
    w = int(max(s[:, 0].max() for s in strokes) + 0.08 * SCAN_SIZE)
    h = int(max(s[:, 1].max() for s in strokes) + 0.08 * SCAN_SIZE)
    ink = np.zeros((h, w), np.float32)
    for s in strokes:
        pts = densify(s, 0.5)
        step = np.gradient(pts, axis=0)
        down = np.clip(step[:, 1] / np.maximum(np.hypot(*step.T), 1e-9), 0, 1)
        for (x, y), d in zip(pts, down, strict=True):
            r = 1.75 + 2.75 * d  # 3.5 px wide going up or across, 9 px going down
            cv2.circle(ink, (round(16 * (x - 0.5)), round(16 * (y - 0.5))), round(16 * r),
                       1.0, -1, cv2.LINE_AA, 4)
    ink = cv2.GaussianBlur(ink, (0, 0), 0.9)
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    paper = 0.93 - 0.16 * (x / w) - 0.04 * (y / h)  # cream, lit from the left
    grain = np.random.default_rng(SCAN_SEED).normal(0.0, 0.025, (h, w)).astype(np.float32)
    grey = paper * (1.0 - 0.82 * ink) + grain
    return np.clip(255.0 * grey, 0, 255).round().astype(np.uint8)


def write_samples(folder: Path) -> list[Path]:
    """Write shapes.png, spiral.svg and brush-scan.png into ``folder``; their paths."""
    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    png, svg, scan = folder / "shapes.png", folder / "spiral.svg", folder / "brush-scan.png"
    rgb = still_life()
    cv2.imwrite(str(png), np.ascontiguousarray(rgb[..., ::-1]),
                [cv2.IMWRITE_PNG_COMPRESSION, 9])
    svg.write_text(spiral_svg())
    cv2.imwrite(str(scan), brush_scan(), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return [png, svg, scan]


if __name__ == "__main__":  # pragma: no cover - python -m inkmotion.samples.generate DIR
    for written in write_samples(Path(sys.argv[1] if len(sys.argv) > 1 else ".")):
        print(written)
