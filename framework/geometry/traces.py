"""Input traces: polylines in canvas pixels (origin top-left, y down)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from inkmotion.errors import InputError

#: readers refuse inputs with more points than this (all strokes together)
MAX_POINTS = 200_000
#: and with more strokes than this: each is a motor plan of its own, whose fit, at a
#: few MB each, would not fit in a machine's memory long before the point limit
MAX_STROKES = 5_000
#: a dot (a stroke of one point, a tap of the pen) is drawn as a stroke this share of
#: the drawing's longer side long, rightwards: at 350 px, a pen's dab 1 px long
DOT_SHARE = 0.003
#: a picture is cropped to what lands on the canvas before it is resized when the whole
#: of it resized would be more than this many canvases (:func:`_warp`)
WARP_CROP = 4.0


@dataclass
class Traces:
    """A drawing as polylines.

    ``strokes`` holds one float64 array per pen-down stroke, each (k, 2) or (k, 3) where
    the third column is the stroke radius in the same units. ``source`` names the input
    for error messages. Readers return traces in their own units; :meth:`fit_to_canvas`
    maps them into a canvas whose longer side is ``size`` px.
    """

    strokes: list[np.ndarray]
    source: str = "<traces>"
    width: float | None = None  # canvas size once fitted
    height: float | None = None
    meta: dict = field(default_factory=dict)
    #: the ink (H, W) in [0, 1] of the picture the strokes were traced from, in the same
    #: coordinates (pixel centres at half-integers); None for recorded traces
    picture: np.ndarray | None = None

    @property
    def n_points(self) -> int:
        return sum(len(s) for s in self.strokes)

    def validated(self) -> Traces:
        """Drop strokes of fewer than 2 distinct points; refuse empty, NaN or huge inputs."""
        if self.n_points > MAX_POINTS:
            raise InputError(
                f"{self.source}: {self.n_points} points is more than the limit of {MAX_POINTS}; "
                "simplify the drawing or split it into several inputs."
            )
        if len(self.strokes) > MAX_STROKES:
            raise InputError(
                f"{self.source}: {len(self.strokes)} strokes is more than the limit of "
                f"{MAX_STROKES}; join or simplify them, or split the drawing into several "
                "inputs."
            )
        kept, dots = [], []
        for s in self.strokes:
            s = np.asarray(s, dtype=np.float64)
            if s.ndim != 2 or s.shape[1] not in (2, 3):
                raise InputError(f"{self.source}: a stroke is not a list of 2-D or 3-D points.")
            if not np.all(np.isfinite(s)):
                raise InputError(
                    f"{self.source}: a stroke holds NaN or infinite coordinates; fix or remove it."
                )
            # remove consecutive duplicates
            keep = np.ones(len(s), dtype=bool)
            keep[1:] = np.any(np.abs(np.diff(s[:, :2], axis=0)) > 1e-12, axis=1)
            s = s[keep]
            if len(s) >= 2:
                kept.append(s)
            elif len(s) == 1:
                dots.append(len(kept))
                kept.append(s)
        meta = dict(self.meta)
        if dots and len(dots) == len(kept) and np.ptp(np.concatenate(kept)[:, :2], axis=0).max(
                ) <= 1e-12:  # taps at one place only: nothing to draw (below)
            kept = []
        elif dots:  # in place: the drawing order stays the recorded one
            kept = _with_dabs(kept, dots)
            said = f"{len(dots)} dots" if len(dots) > 1 else "dot"
            meta["notes"] = [*meta.get("notes", []), f"its {said} (a stroke of one point, "
                             f"a tap of the pen) {'are' if len(dots) > 1 else 'is'} drawn as "
                             f"{'dabs' if len(dots) > 1 else 'a dab'}, a stroke "
                             f"{DOT_SHARE:.1%} of the drawing long"]
        if not kept:
            raise InputError(
                f"{self.source}: no stroke has two distinct points, so there is nothing to draw; "
                "check that the file holds a drawing."
            )
        lo = np.min([s[:, :2].min(axis=0) for s in kept], axis=0)
        hi = np.max([s[:, :2].max(axis=0) for s in kept], axis=0)
        if np.max(hi - lo) <= 1e-12:
            raise InputError(f"{self.source}: all points are equal, so there is nothing to draw.")
        return Traces(kept, self.source, self.width, self.height, meta, self.picture)

    def fit_to_canvas(self, size: float, margin: float = 0.08) -> Traces:
        """Scale uniformly (aspect kept) so the bounding box fills a canvas of longer side
        ``size`` px with ``margin`` (fraction of size) on each side. Radii scale too."""
        t = self.validated()
        lo = np.min([s[:, :2].min(axis=0) for s in t.strokes], axis=0)
        hi = np.max([s[:, :2].max(axis=0) for s in t.strokes], axis=0)
        extent = hi - lo
        inner = size * (1.0 - 2.0 * margin)
        scale = inner / float(np.max(extent))
        canvas = np.maximum(np.ceil(extent * scale + 2.0 * margin * size), 8.0)
        offset = (canvas - extent * scale) / 2.0
        strokes = []
        for s in t.strokes:
            out = s.copy()
            out[:, :2] = (s[:, :2] - lo) * scale + offset
            if s.shape[1] == 3:
                out[:, 2] = s[:, 2] * scale
            strokes.append(out)
        meta = dict(t.meta)
        picture = None
        if t.picture is not None:
            picture = _warp(t.picture, scale, offset - lo * scale, canvas)
            meta["canvas_from_picture"] = {"scale": scale,
                                           "offset": (offset - lo * scale).tolist()}
        return Traces(strokes, t.source, float(canvas[0]), float(canvas[1]), meta, picture)


def _warp(image: np.ndarray, scale: float, shift: np.ndarray, canvas: np.ndarray) -> np.ndarray:
    """``image`` mapped by p ↦ scale·p + shift (pixel centres at half-integers) onto a
    canvas (width, height): area-averaged when it shrinks, bilinear otherwise. Where the
    whole image resized would be more than :data:`WARP_CROP` canvases (a small drawing
    in a large picture, enlarged to fill the canvas), only the part that lands on the
    canvas and a pixel round it is resized, so the cost is the canvas's, not the
    picture's times the enlargement."""
    import cv2

    h, w = image.shape
    if (w * scale) * (h * scale) > WARP_CROP * float(canvas[0]) * float(canvas[1]):
        # image pixels x with scale·(x + ½) + shift on the canvas: a whole-pixel window
        lo = np.floor(-np.asarray(shift) / scale - 1.0).astype(int)
        hi = np.ceil((np.asarray(canvas) - shift) / scale + 1.0).astype(int)
        (x0, y0), (x1, y1) = np.maximum(lo, 0), np.minimum(hi, (w, h))
        if x1 <= x0 or y1 <= y0:
            return np.zeros((int(canvas[1]), int(canvas[0])), dtype=np.float32)
        image = image[y0:y1, x0:x1]
        shift = np.asarray(shift, dtype=np.float64) + scale * np.array([x0, y0])
        h, w = image.shape
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    sx, sy = size[0] / w, size[1] / h
    resized = cv2.resize(image.astype(np.float32), size,
                         interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    # resized pixel u has its centre at (u + ½)/s in the image: canvas = scale·that + shift
    m = np.array([[scale / sx, 0.0, shift[0] + 0.5 * scale / sx - 0.5],
                  [0.0, scale / sy, shift[1] + 0.5 * scale / sy - 0.5]])
    return cv2.warpAffine(resized, m, (int(canvas[0]), int(canvas[1])),
                          flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                          borderValue=0.0)


def _with_dabs(strokes: list[np.ndarray], dots: list[int]) -> list[np.ndarray]:
    """``strokes`` with each dot among them (the indices ``dots``, (1, D) points) made a
    stroke of two points, :data:`DOT_SHARE` of the longer side of the whole drawing long,
    rightwards from the dot."""
    every = np.concatenate([s[:, :2] for s in strokes])
    step = np.zeros(strokes[dots[0]].shape[1])
    step[0] = DOT_SHARE * float(np.max(every.max(axis=0) - every.min(axis=0)))
    return [np.vstack((s, s + step)) if i in set(dots) else s for i, s in enumerate(strokes)]
