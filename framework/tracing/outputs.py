"""What ``inkmotion trace`` writes, so a user can check the extraction before a fit:

- ``strokes.svg``: each stroke a path in drawing order, coloured along a rainbow from the
  first to the last, with an arrow head at its end and its number at its start (of the
  class :data:`inkmotion.inputs.svg.ANNOTATION_CLASS`, which the SVG reader does not
  draw);
- ``strokes.gml``: the strokes as a GML tag (points normalised to the picture's longer
  side, y down; times none), which any GML tool opens and ``inkmotion run fit`` reads;
- ``strokes.png``: the strokes over the picture, numbered, with arrows (and in a photo of
  a page on a desk, the outline of the page found, in black: what lies outside it was
  left out);
- ``extraction.json``: the figures of :func:`inkmotion.tracing.trace_picture`.

A corrected ``strokes.svg`` or ``strokes.gml`` is fitted like any recorded trace."""

from __future__ import annotations

import colorsys
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from inkmotion.geometry.traces import Traces
from inkmotion.inputs.svg import ANNOTATION_CLASS
from inkmotion.json_files import dumps


def stroke_colours(n: int) -> list[tuple[int, int, int]]:
    """``n`` RGB colours from red (first stroke) through to violet (last)."""
    return [tuple(int(255 * c) for c in colorsys.hsv_to_rgb(0.8 * i / max(n - 1, 1), 0.9, 0.8))
            for i in range(n)]  # type: ignore[misc]


def _arrow(pts: np.ndarray, size: float) -> np.ndarray | None:
    """Three points of an arrow head at the end of ``pts`` (k, ≥2), or None if too short."""
    end = pts[-1, :2]
    back = pts[:-1, :2][np.hypot(*(pts[:-1, :2] - end).T) >= size]
    if len(back) == 0:
        return None
    d = end - back[-1]
    d = d / np.hypot(*d)
    n = np.array([-d[1], d[0]])
    return np.array([end - size * d + 0.5 * size * n, end, end - size * d - 0.5 * size * n])


def strokes_svg(traces: Traces, width: int, height: int) -> str:
    """The SVG text of ``strokes.svg`` (module docstring)."""
    n = len(traces.strokes)
    size = max(4.0, 0.015 * max(width, height))
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
             f'viewBox="0 0 {width} {height}">',
             f"<title>{escape(Path(traces.source).name)}: {n} strokes in drawing order</title>"]
    for i, (s, rgb) in enumerate(zip(traces.strokes, stroke_colours(n), strict=True)):
        colour = "#{:02x}{:02x}{:02x}".format(*rgb)
        d = "M " + " L ".join(f"{x:.2f},{y:.2f}" for x, y in s[:, :2])
        parts.append(f'<path id="stroke-{i + 1}" d="{d}" fill="none" stroke="{colour}" '
                     f'stroke-width="{size / 4:.2f}" stroke-linecap="round" '
                     'stroke-linejoin="round"/>')
        head = _arrow(s, size)
        if head is not None:
            pts = " ".join(f"{x:.2f},{y:.2f}" for x, y in head)
            parts.append(f'<polyline class="{ANNOTATION_CLASS}" points="{pts}" fill="none" '
                         f'stroke="{colour}" stroke-width="{size / 4:.2f}"/>')
        x, y = s[0, :2]
        parts.append(f'<text class="{ANNOTATION_CLASS}" x="{x:.1f}" y="{y - size / 2:.1f}" '
                     f'font-size="{1.5 * size:.1f}" fill="{colour}" '
                     f'font-family="sans-serif">{i + 1}</text>')
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


def strokes_gml(traces: Traces, width: int, height: int) -> str:
    """The GML text of ``strokes.gml``: points as fractions of the longer side, screen
    bounds the picture's aspect, so reading it back gives the strokes' shape."""
    longer = float(max(width, height))
    strokes = []
    for s in traces.strokes:
        pts = "".join(f"<pt><x>{x / longer:.6f}</x><y>{y / longer:.6f}</y></pt>"
                      for x, y in s[:, :2])
        strokes.append(f"<stroke>{pts}</stroke>")
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<gml spec="1.0"><tag><header><client>'
            f"<name>inkmotion trace</name></client><environment><screenBounds><x>1</x>"
            f"<y>1</y></screenBounds><up><x>0</x><y>-1</y><z>0</z></up></environment>"
            f"</header><drawing>{''.join(strokes)}</drawing></tag></gml>\n")


def strokes_png(traces: Traces, grey: np.ndarray, path: Path,
                page: np.ndarray | None = None) -> None:
    """``strokes.png``: the picture (faded) with the strokes drawn over it, and the
    outline of the ``page`` found in a photo (H, W) bool, if any, in black."""
    import cv2

    base = np.clip(0.55 + 0.45 * grey, 0, 1)
    img = np.ascontiguousarray(np.repeat((base * 255).astype(np.uint8)[..., None], 3, 2))
    n = len(traces.strokes)
    h, w = grey.shape
    thick = max(1, round(max(h, w) / 400))
    if page is not None:
        outline = cv2.findContours(page.astype(np.uint8), cv2.RETR_EXTERNAL,
                                   cv2.CHAIN_APPROX_SIMPLE)[0]
        cv2.drawContours(img, outline, -1, (0, 0, 0), thick, cv2.LINE_AA)
    size = max(6.0, 0.02 * max(h, w))
    for i, (s, rgb) in enumerate(zip(traces.strokes, stroke_colours(n), strict=True)):
        bgr = rgb[::-1]
        pts = np.round(s[:, :2] * 16).astype(np.int32)
        cv2.polylines(img, [pts], False, bgr, thick, cv2.LINE_AA, 4)
        head = _arrow(s, size)
        if head is not None:
            cv2.polylines(img, [np.round(head * 16).astype(np.int32)], False, bgr, thick,
                          cv2.LINE_AA, 4)
        x, y = s[0, :2]
        cv2.circle(img, (int(x), int(y)), thick + 2, bgr, -1, cv2.LINE_AA)
        cv2.putText(img, str(i + 1), (int(x) + 3, int(y) - 3), cv2.FONT_HERSHEY_SIMPLEX,
                    size / 25, bgr, thick, cv2.LINE_AA)
    cv2.imwrite(str(path), img)


def write_trace(traces: Traces, grey: np.ndarray, folder: Path,
                page: np.ndarray | None = None) -> list[str]:
    """Write the four files (module docstring) into ``folder``; their names. ``page``:
    the page found in a photo, outlined in strokes.png."""
    h, w = grey.shape
    (folder / "strokes.svg").write_text(strokes_svg(traces, w, h))
    (folder / "strokes.gml").write_text(strokes_gml(traces, w, h))
    strokes_png(traces, grey, folder / "strokes.png", page)
    (folder / "extraction.json").write_text(dumps(traces.meta.get("extraction", {}),
                                                       indent=1) + "\n")
    return ["strokes.svg", "strokes.gml", "strokes.png", "extraction.json"]
