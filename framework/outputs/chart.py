"""Line charts drawn with OpenCV: the plots a fit job writes (speed.png, human_speeds.png).

A :class:`Chart` has one box of axes with ticks at round numbers, axis titles, a title
and an optional legend (one row above the axes, where it covers no data); on it go faint
bands, vertical rules and polylines, in the order they are added. It is drawn
:data:`SUPERSAMPLE` times larger and then reduced with area averaging, which smooths
OpenCV's anti-aliased lines and text.

Why not matplotlib, which draws the evaluation's other figures: a fit's plots are simple
line charts, and matplotlib's import and first figure cost about 0.45 s of a 3-s fit
(0.1 s a plot after that), where OpenCV, loaded anyway for overlay.png, draws one in about
10 ms. OpenCV's Hershey fonts are ASCII only, so labels here are too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from inkmotion.outputs.images import bgr, write_image

#: drawn this many times larger, then reduced with area averaging
SUPERSAMPLE = 2
FONT = cv2.FONT_HERSHEY_SIMPLEX
#: font scale of tick labels, axis titles and the legend, and of the title, at the final size
LABEL_SCALE = 0.42
TITLE_SCALE = 0.40
#: line weights: OpenCV thickness in supersampled px (1: a thin line, 2: the main curve)
THIN, BOLD = 1, 2
#: margins (left, top, right, bottom) around the axes, px at the final size
MARGINS = (70, 30, 18, 50)
TICK = 4


def nice_ticks(top: float, count: int = 7) -> np.ndarray:
    """Ticks from 0 to ``top`` at a step of 1, 2, 2.5 or 5 × 10^k, about ``count`` of them."""
    assert top > 0 and math.isfinite(top), top
    raw = top / count
    magnitude = 10.0 ** math.floor(math.log10(raw))
    step = next(s * magnitude for s in (1.0, 2.0, 2.5, 5.0, 10.0) if s * magnitude >= raw)
    return step * np.arange(0, math.floor(top / step * (1 + 1e-9)) + 1)


def tick_label(value: float) -> str:
    """A tick's number without round-off digits: 2.5, 600, 0.125."""
    return f"{round(value, 9):g}"


class Chart:
    """A ``size`` (width, height px) chart of x in [0, ``x_max``] and y in [0, ``y_max``]."""

    def __init__(self, size: tuple[int, int], x_max: float, y_max: float, *,
                 title: str = "", x_label: str = "", y_label: str = "",
                 y_ticks_to: float | None = None) -> None:
        """``y_ticks_to``: the highest y a tick may mark (default ``y_max``), so a chart
        with headroom above its data does not label the headroom."""
        assert 0 < x_max < math.inf and 0 < y_max < math.inf, (x_max, y_max)
        s = SUPERSAMPLE
        self.size = size
        self.x_max, self.y_max = float(x_max), float(y_max)
        self.y_ticks_to = float(y_ticks_to if y_ticks_to is not None else y_max)
        self.title, self.x_label, self.y_label = title, x_label, y_label
        left, top, right, bottom = MARGINS
        width, height = size
        self.box = (left * s, top * s, (width - right) * s, (height - bottom) * s)
        self.canvas = np.full((height * s, width * s, 3), 255, np.uint8)
        self._legend: list[tuple[str, tuple[int, int, int], int]] = []

    def _x(self, x: np.ndarray | float) -> np.ndarray:
        left, _, right, _ = self.box
        return left + np.asarray(x, dtype=float) / self.x_max * (right - left)

    def _y(self, y: np.ndarray | float) -> np.ndarray:
        _, top, _, bottom = self.box
        return bottom - np.asarray(y, dtype=float) / self.y_max * (bottom - top)

    def _points(self, x: np.ndarray, y: np.ndarray) -> list[np.ndarray]:
        """(k, 2) int32 points at 1/16 px (OpenCV's ``shift`` = 4), one array per run of
        finite values (a NaN or an infinity breaks the line, as in matplotlib), each
        point kept within a canvas's reach of the axes."""
        px, py = self._x(x), self._y(y)
        ok = np.isfinite(px) & np.isfinite(py)
        reach = 4.0 * max(self.canvas.shape)
        xy = np.clip(np.column_stack((px, py)), -reach, reach)
        edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(np.int8), [0]))))
        return [np.round(16.0 * xy[i:j]).astype(np.int32)
                for i, j in zip(edges[::2], edges[1::2], strict=True) if j - i > 1]

    def band(self, x0: float, x1: float, grey: int = 240) -> None:
        """A faint vertical band over x in [x0, x1], the axes' full height."""
        _, top, _, bottom = self.box
        cv2.rectangle(self.canvas, (round(float(self._x(x0))), top),
                      (round(float(self._x(x1))), bottom), (grey,) * 3, -1)

    def rule(self, x: float, rgb: tuple[int, int, int], weight: int = THIN) -> None:
        """A vertical line at ``x`` across the axes."""
        _, top, _, bottom = self.box
        px = round(float(self._x(x)))
        cv2.line(self.canvas, (px, top), (px, bottom), bgr(rgb), weight)

    def lines(self, curves: Sequence[tuple[np.ndarray, np.ndarray]], rgb: tuple[int, int, int],
              weight: int = THIN, label: str | None = None) -> None:
        """Polylines (x (n,), y (n,)) in ``rgb``; ``label``: their entry in the legend."""
        points = [run for x, y in curves for run in self._points(np.asarray(x, float),
                                                                 np.asarray(y, float))]
        if points:
            cv2.polylines(self.canvas, points, False, bgr(rgb), weight, cv2.LINE_AA, 4)
        if label:
            self._legend.append((label, rgb, weight))

    def _text(self, text: str, anchor: tuple[float, float], scale: float,
              align: tuple[float, float]) -> int:
        """``text`` with ``align`` (0 left/top … 1 right/bottom) of its box at ``anchor``;
        its width (supersampled px)."""
        s = SUPERSAMPLE
        (w, h), base = cv2.getTextSize(text, FONT, scale * s, s)
        x = anchor[0] - align[0] * w
        y = anchor[1] - align[1] * (h + base) + h
        cv2.putText(self.canvas, text, (round(x), round(y)), FONT, scale * s, (0, 0, 0), s,
                    cv2.LINE_AA)
        return w

    def _vertical_text(self, text: str, centre: tuple[float, float], scale: float) -> None:
        """``text`` turned a quarter anticlockwise, centred on ``centre``."""
        s = SUPERSAMPLE
        (w, h), base = cv2.getTextSize(text, FONT, scale * s, s)
        pad = 2 * s
        patch = np.full((h + base + 2 * pad, w + 2 * pad, 3), 255, np.uint8)
        cv2.putText(patch, text, (pad, pad + h), FONT, scale * s, (0, 0, 0), s, cv2.LINE_AA)
        patch = cv2.rotate(patch, cv2.ROTATE_90_COUNTERCLOCKWISE)
        y0 = max(round(centre[1] - patch.shape[0] / 2), 0)
        x0 = max(round(centre[0] - patch.shape[1] / 2), 0)
        region = self.canvas[y0:y0 + patch.shape[0], x0:x0 + patch.shape[1]]
        np.minimum(region, patch[:region.shape[0], :region.shape[1]], out=region)

    def _frame(self) -> None:
        """Box, ticks with their labels, axis titles, title and legend."""
        s = SUPERSAMPLE
        left, top, right, bottom = self.box
        tick = TICK * s
        cv2.rectangle(self.canvas, (left, top), (right, bottom), (0, 0, 0), s)
        for x in nice_ticks(self.x_max):
            px = round(float(self._x(x)))
            cv2.line(self.canvas, (px, bottom), (px, bottom + tick), (0, 0, 0), s)
            self._text(tick_label(x), (px, bottom + tick + 4 * s), LABEL_SCALE, (0.5, 0.0))
        widest = 0
        for y in nice_ticks(self.y_ticks_to):
            py = round(float(self._y(y)))
            cv2.line(self.canvas, (left - tick, py), (left, py), (0, 0, 0), s)
            widest = max(widest, self._text(tick_label(y), (left - tick - 4 * s, py),
                                            LABEL_SCALE, (1.0, 0.5)))
        if self.x_label:
            self._text(self.x_label, ((left + right) / 2, bottom + tick + 22 * s), LABEL_SCALE,
                       (0.5, 0.0))
        if self.y_label:
            self._vertical_text(self.y_label, (max(left - tick - widest - 14 * s, 9 * s),
                                               (top + bottom) / 2), LABEL_SCALE)
        if self.title:
            self._text(self.title, ((left + right) / 2, top - 8 * s), TITLE_SCALE, (0.5, 1.0))
        self._draw_legend()

    def _draw_legend(self) -> None:
        """The labelled lines' entries in one row above the axes, flush right, where they
        cover no data."""
        if not self._legend:
            return
        s = SUPERSAMPLE
        _, top, right, _ = self.box
        sample, gap = 24 * s, 16 * s
        y = top - 9 * s
        x = right
        for label, rgb, weight in reversed(self._legend):
            x -= self._text(label, (x, y), LABEL_SCALE, (1.0, 0.5)) + 6 * s + sample
            cv2.line(self.canvas, (x, y), (x + sample, y), bgr(rgb), weight + s, cv2.LINE_AA)
            x -= gap

    def write(self, path: str | Path) -> None:
        """Draw the frame and text, reduce to ``size`` and write the image file."""
        self._frame()
        write_image(path, cv2.resize(self.canvas, self.size, interpolation=cv2.INTER_AREA))
