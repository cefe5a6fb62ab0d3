"""The drawing the simulated pen left: where it touched the board, mapped back from the
drawing plane into the plan's canvas pixels (black ink on white), to set beside the fitted
drawing.png."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import cv2
import numpy as np

#: plane coordinates (K, 2) m -> canvas pixels (K, 2)
PlaneToCanvas = Callable[[np.ndarray], np.ndarray]

_SHIFT = 4  # sub-pixel bits for cv2 drawing


def plane_coordinates(points: np.ndarray, origin: np.ndarray,
                      rotation: np.ndarray) -> np.ndarray:
    """(u, v) m of points (K, 3) in the plane frame (origin, columns u, v, normal)."""
    return (np.asarray(points, dtype=float) - origin) @ np.asarray(rotation)[:, :2]


def paper_mapping(paper: tuple[float, float], canvas: tuple[int, int]) -> PlaneToCanvas:
    """The default mapping: the paper [0, w] × [0, h] (u, v) stretched onto the canvas
    [0, W] × [0, H] px, u → x and v → y. Pass the timing's own mapping where it differs."""
    scale = np.array([canvas[0] / paper[0], canvas[1] / paper[1]])
    return lambda uv: np.asarray(uv) * scale


def _polylines(contact_points: np.ndarray | Sequence[np.ndarray],
               max_gap: float | None) -> list[np.ndarray]:
    """Contact points as polylines: a list is taken as given; one (K, 3) array is split
    where consecutive points are more than ``max_gap`` m apart (a pen lift)."""
    if isinstance(contact_points, np.ndarray):
        points = contact_points.reshape(-1, 3)
        if len(points) == 0:
            return []
        if max_gap is None:
            return [points]
        gaps = np.linalg.norm(np.diff(points, axis=0), axis=1)
        return np.split(points, np.flatnonzero(gaps > max_gap) + 1)
    return [np.asarray(p, dtype=float).reshape(-1, 3) for p in contact_points if len(p)]


def render_sim_drawing(contact_points: np.ndarray | Sequence[np.ndarray],
                       board_origin: np.ndarray, board_rotation: np.ndarray,
                       paper: tuple[float, float], canvas: tuple[int, int], *,
                       mapping: PlaneToCanvas | None = None, width_px: float = 3.0,
                       max_gap: float | None = 0.003) -> np.ndarray:
    """(H, W) uint8 image, 255 white, of the ink: each polyline of contact points (see
    ``SimResult.contact_strokes``, or one (K, 3) array split at gaps > ``max_gap`` m)
    projected on the plane, mapped to canvas px by ``mapping`` (default
    ``paper_mapping``) and drawn ``width_px`` wide, anti-aliased."""
    w_px, h_px = int(round(canvas[0])), int(round(canvas[1]))
    to_canvas = mapping if mapping is not None else paper_mapping(paper, (w_px, h_px))
    image = np.full((h_px, w_px), 255, dtype=np.uint8)
    thickness = max(1, int(round(width_px)))
    origin, rotation = np.asarray(board_origin, float), np.asarray(board_rotation, float)
    for line in _polylines(contact_points, max_gap):
        px = np.asarray(to_canvas(plane_coordinates(line, origin, rotation)), dtype=float)
        fixed = np.round(px * (1 << _SHIFT)).astype(np.int32).reshape(-1, 1, 2)
        if len(fixed) == 1:
            cv2.circle(image, tuple(int(c) for c in fixed[0, 0]), (thickness << _SHIFT) // 2,
                       0, -1, cv2.LINE_AA, _SHIFT)
        else:
            cv2.polylines(image, [fixed], False, 0, thickness, cv2.LINE_AA, _SHIFT)
    return image


def write_sim_drawing(path: str | Path, contact_points: np.ndarray | Sequence[np.ndarray],
                      board_origin: np.ndarray, board_rotation: np.ndarray,
                      paper: tuple[float, float], canvas: tuple[int, int], *,
                      mapping: PlaneToCanvas | None = None, width_px: float = 3.0,
                      max_gap: float | None = 0.003) -> Path:
    """Write ``render_sim_drawing`` as a PNG (sim_drawing.png) and return its path."""
    path = Path(path)
    image = render_sim_drawing(contact_points, board_origin, board_rotation, paper, canvas,
                               mapping=mapping, width_px=width_px, max_gap=max_gap)
    if not cv2.imwrite(str(path), image):
        raise OSError(f"could not write {path}; check that its folder exists and is writable")
    return path


def write_side_by_side(path: str | Path, left_png: str | Path, right_png: str | Path, *,
                       labels: tuple[str, str] | None = ("plan", "simulation"),
                       gap: int = 8) -> Path:
    """Two PNGs next to each other on white (the shorter padded at the bottom), each with
    an optional caption above it: e.g. drawing.png beside sim_drawing.png."""
    images = []
    for png in (left_png, right_png):
        image = cv2.imread(str(png), cv2.IMREAD_COLOR)
        if image is None:
            raise OSError(f"could not read {png}; check that it is a PNG file")
        images.append(image)
    header = 24 if labels else 0
    height = max(i.shape[0] for i in images) + header
    width = sum(i.shape[1] for i in images) + gap
    out = np.full((height, width, 3), 255, dtype=np.uint8)
    x = 0
    for k, image in enumerate(images):
        out[header:header + image.shape[0], x:x + image.shape[1]] = image
        if labels:
            cv2.putText(out, labels[k], (x + 4, 17), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                        (0, 0, 0), 1, cv2.LINE_AA)
        x += image.shape[1] + gap
    path = Path(path)
    if not cv2.imwrite(str(path), out):
        raise OSError(f"could not write {path}; check that its folder exists and is writable")
    return path
