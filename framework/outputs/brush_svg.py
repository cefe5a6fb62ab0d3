"""Brush outlines: a varying-width (2.5D) stroke as the filled region it covers, for
drawing.svg (printing, cutting, vector editors), with its centre line on a layer of its
own for pen plotters.

A 3-D plan's cubic segments (S, 4, 3) carry the stroke radius r in px as their third
coordinate. Each segment is sampled at ``per_segment`` + 1 parameters; between two
consecutive samples a, b the brush covers the convex hull of the discs of radius r_a at a
and r_b at b (a tapered capsule: the radius varies linearly along the piece, as in the
'raster' renderer). The outline is the union of these pieces (shapely's ``unary_union``),
so joins and caps are round and overlaps of a stroke with itself are one region; holes
(a loop around paper) are kept and written with ``fill-rule="evenodd"``.

The SVG has two top-level ``<g>`` layers (Inkscape layers; ``vpype read`` makes one layer
per top-level group): ``outlines`` (the filled regions, one ``<path>`` per trajectory) and
``centre-lines`` (the trajectories as cubic Béziers, stroked 0.5 px), so a pen plotter can
take the centre lines and a printer the outlines.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

#: samples per cubic segment along which the outline follows the radius
PER_SEGMENT = 8
#: segments of a quarter circle in the discs (shapely's quad_segs)
QUAD_SEGS = 16


def _samples(segments: torch.Tensor, per_segment: int) -> np.ndarray:
    """Points (S·k + 1, 3) along the cubics (S, 4, 3), k = ``per_segment``."""
    ctrl = segments.detach().to("cpu", torch.float64).numpy()  # (S, 4, 3)
    u = np.linspace(0.0, 1.0, per_segment + 1)[:-1][None, :, None]  # (1, k, 1)
    a = 1.0 - u
    pts = (a**3 * ctrl[:, None, 0] + 3 * a**2 * u * ctrl[:, None, 1]
           + 3 * a * u**2 * ctrl[:, None, 2] + u**3 * ctrl[:, None, 3])  # (S, k, 3)
    return np.vstack((pts.reshape(-1, 3), ctrl[-1:, 3]))


def brush_outline(segments: torch.Tensor, per_segment: int = PER_SEGMENT) -> Any:
    """The region (a shapely Polygon or MultiPolygon, px) that a brush of radius r(u) covers
    along the cubics ``segments`` (S, 4, 3) (module docstring)."""
    from shapely import MultiPoint, Point, unary_union

    pts = _samples(segments, per_segment)
    radius = np.maximum(pts[:, 2], 0.0)
    discs = [Point(x, y).buffer(r, quad_segs=QUAD_SEGS) if r > 0 else Point(x, y)
             for x, y, r in pts]
    pieces = []
    for i in range(len(pts) - 1):
        hull = MultiPoint([]).union(discs[i]).union(discs[i + 1]).convex_hull
        pieces.append(hull)
    if not pieces:
        return discs[0] if radius[0] > 0 else Point(pts[0, 0], pts[0, 1]).buffer(0.0)
    return unary_union(pieces)


def _ring(coords: Any) -> str:
    xy = np.asarray(coords)[:-1]  # closed rings repeat their first point
    if len(xy) < 3:
        return ""
    head = f"M {xy[0, 0]:.3f} {xy[0, 1]:.3f}"
    return head + " " + " ".join(f"L {x:.3f} {y:.3f}" for x, y in xy[1:]) + " Z"


def outline_path_data(region: Any) -> str:
    """SVG path data of a shapely (Multi)Polygon: every exterior and interior ring, closed
    (to be filled with ``fill-rule="evenodd"``)."""
    polygons = getattr(region, "geoms", [region])
    rings = []
    for poly in polygons:
        if poly.is_empty or not hasattr(poly, "exterior"):
            continue
        rings.append(_ring(poly.exterior.coords))
        rings.extend(_ring(hole.coords) for hole in poly.interiors)
    return " ".join(r for r in rings if r)


def brush_layers(segments_per_path: list[torch.Tensor], path_data: Any) -> list[str]:
    """The two SVG layers (outlines, centre lines) of 3-D trajectories, as lines of XML;
    ``path_data`` turns segments into the centre line's path data."""
    lines = ['<g id="outlines" inkscape:groupmode="layer" inkscape:label="outlines" '
             'fill="#000000" stroke="none" fill-rule="evenodd">\n']
    for i, seg in enumerate(segments_per_path):
        d = outline_path_data(brush_outline(seg)) if len(seg) else ""
        if d:
            lines.append(f'<path id="outline{i}" d="{d}"/>\n')
    lines.append("</g>\n")
    lines.append('<g id="centre-lines" inkscape:groupmode="layer" inkscape:label="centre '
                 'lines" fill="none" stroke="#000000" stroke-width="0.5" '
                 'stroke-linecap="round" stroke-linejoin="round">\n')
    for i, seg in enumerate(segments_per_path):
        d = path_data(seg)
        if d:
            lines.append(f'<path id="centre{i}" d="{d}"/>\n')
    lines.append("</g>\n")
    return lines
