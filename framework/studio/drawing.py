"""A drawing made on the studio's page: pointer strokes with their times, as a GML tag.

The page records every ``pointermove`` of a pressed mouse, pen or finger (coalesced events
included) as ``[x, y, t, pressure]``: x, y in CSS px of the drawing area, t in ms of the
page's clock (``PointerEvent.timeStamp``), pressure in 0..1 (0.5 for a mouse, as the
Pointer Events spec gives it). :func:`drawing_gml` turns those strokes into GML 1.0: x by
the area's width and y by its height, ``screenBounds`` the area's size (so the reader
restores its aspect), t in seconds from the drawing's first point, strictly increasing
within the drawing (a point whose time does not advance is dropped: it carries no motion),
and the pressure kept on each point. The fit reads it like any recorded tag, so the
recorded speed is there to compare with.
"""

from __future__ import annotations

import math
from typing import Any

from inkmotion.errors import InputError

#: the most strokes and points a drawing from the page may have
MAX_STROKES = 500
MAX_POINTS = 50_000


def drawing_gml(payload: Any) -> str:
    """The GML text of a drawing sent by the page: ``{"width": W, "height": H,
    "strokes": [[[x, y, t_ms, pressure], ...], ...]}``. Raises :class:`InputError` (one
    sentence) for anything else, or a drawing with no stroke of two points."""
    if not isinstance(payload, dict):
        raise InputError("The drawing is not a JSON object; draw again on the page.")
    width, height = _number(payload.get("width")), _number(payload.get("height"))
    strokes = payload.get("strokes")
    if not (width and height and width > 0 and height > 0) or not isinstance(strokes, list):
        raise InputError("The drawing has no size or no strokes; draw again on the page.")
    if len(strokes) > MAX_STROKES or sum(len(s) for s in strokes
                                         if isinstance(s, list)) > MAX_POINTS:
        raise InputError(f"The drawing has more than {MAX_STROKES} strokes or "
                         f"{MAX_POINTS} points; draw something smaller.")
    kept: list[list[tuple[float, float, float, float]]] = []
    t0: float | None = None
    last = -math.inf
    for stroke in strokes:
        points = []
        for point in stroke if isinstance(stroke, list) else []:
            if not isinstance(point, list) or len(point) < 3:
                raise InputError("A point of the drawing is not [x, y, t, pressure]; "
                                 "draw again on the page.")
            x, y, t = _number(point[0]), _number(point[1]), _number(point[2])
            p = _number(point[3]) if len(point) > 3 else 0.5
            if x is None or y is None or t is None:
                raise InputError("A point of the drawing is not a finite number; draw "
                                 "again on the page.")
            t0 = t if t0 is None else t0
            ts = (t - t0) / 1000.0
            if ts <= last:
                continue  # no time passed: no motion to record
            last = ts
            points.append((x / width, y / height, ts, min(1.0, max(0.0, p or 0.0))))
        if len(points) >= 2:
            kept.append(points)
    if not kept:
        raise InputError("The drawing has no stroke of two points or more; draw a line "
                         "on the page.")
    body = "".join(
        "<stroke>" + "".join(f"<pt><x>{x:.6f}</x><y>{y:.6f}</y><t>{t:.4f}</t>"
                             f"<pressure>{p:.3f}</pressure></pt>" for x, y, t, p in s)
        + "</stroke>" for s in kept)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<gml spec="1.0"><tag><header><client>'
            "<name>inkmotion studio</name></client><environment><screenBounds>"
            f"<x>{width:.1f}</x><y>{height:.1f}</y></screenBounds><up><x>0</x><y>-1</y>"
            f"<z>0</z></up></environment></header><drawing>{body}</drawing></tag></gml>\n")


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    value = float(value)
    return value if math.isfinite(value) else None
