"""Pictures of line drawings into traces: the ink (:mod:`.picture`), then its strokes,
their order, direction and width (:mod:`.strokes`).

:func:`trace_picture` is the built-in method behind the 'skeleton' tracer plugin and the
'image' reader; the traces it returns carry the picture's ink (``Traces.picture``) so a
fit compares its rendering with the picture itself (its darkness over the ink's own
level, :attr:`Picture.target`), and ``meta["extraction"]`` for the report."""

from __future__ import annotations

import time

import numpy as np

from inkmotion.geometry.traces import Traces
from inkmotion.tracing.picture import Picture, is_picture, read_picture

__all__ = ["Picture", "is_picture", "read_picture", "trace_picture"]


def trace_picture(picture: Picture, varying_width: bool = False) -> Traces:
    """Traces of ``picture``: one stroke per pen-down, in drawing order, as (x, y) in the
    picture's pixels, or (x, y, radius) with ``varying_width``; ``picture`` attached
    (its ink darkness) and ``meta["extraction"]`` (strokes, junctions, tips, spurs, loops,
    dots, pen lifts, ink widths, seconds)."""
    from inkmotion.errors import InputError
    from inkmotion.tracing.strokes import stroke_graph

    start = time.perf_counter()
    graph = stroke_graph(picture.mask, picture.ruling)
    if not graph.strokes:
        raise InputError(f"{picture.source}: no stroke could be traced in the ink; check that "
                         "the picture is a line drawing.")
    radii = np.concatenate([s[:, 2] for s in graph.strokes])
    strokes = [s if varying_width else s[:, :2].copy() for s in graph.strokes]
    extraction = {
        "strokes": len(strokes), "pen_lifts": len(strokes) - 1,
        "junctions": graph.junctions, "tips": graph.tips, "spurs_dropped": graph.spurs,
        "loops": graph.loops, "dots": graph.dots,
        "ink_width_px": {"median": float(2 * np.median(radii)),
                         "p10": float(2 * np.percentile(radii, 10)),
                         "p90": float(2 * np.percentile(radii, 90))},
        "picture_px": [int(picture.shape[1]), int(picture.shape[0])],
        "decoded_scale": picture.scale, "inverted": picture.inverted,
        "ink_level": round(picture.ink_level, 3),
        "notes": list(picture.notes),
        "seconds": round(time.perf_counter() - start, 4),
    }
    return Traces(strokes, picture.source, meta={"extraction": extraction},
                  picture=picture.target)
