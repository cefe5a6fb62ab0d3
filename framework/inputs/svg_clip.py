"""SVG clip paths for the SVG reader: only the part of a path inside its ``clip-path`` is
drawn (svgelements 1.9 parses ``<clipPath>`` but applies none, so a matplotlib line clipped
to its axes, or artwork cut by an Illustrator or Figma frame, was drawn whole).

Two steps around svgelements' parse:

1. :func:`mark_clip_regions`, on the document's XML: each element that names a clip path
   (``clip-path="url(#id)"``, as an attribute or in its ``style``) gets a marker
   attribute ``data-inkmotion-clip-N`` (which svgelements, like every attribute, hands
   down to the shapes inside it), and a copy of the clip path's shapes is placed beside
   it in a group ``data-inkmotion-region="N"`` with the element's own ``transform`` (and
   the ``<clipPath>``'s): svgelements then puts the region's shapes in the same
   coordinates as the element's, which is where SVG applies a clip path
   (``clipPathUnits="userSpaceOnUse"``, the default).
2. :func:`clip_polylines`, after flattening: each region is the union of its shapes'
   closed outlines (shapely), and a polyline is cut to the part inside every region its
   shape is marked with, its pieces in their order along it.

Not applied (the element is drawn whole): ``clipPathUnits="objectBoundingBox"``, a clip
path that is missing, and ``clip-rule`` (a region is the union of its outlines: a shape
with a hole clips as if it had none).
"""

from __future__ import annotations

import copy
import re
from typing import Any

import numpy as np

#: the marker attributes (module docstring)
CLIP_MARK = "data-inkmotion-clip-"
REGION_MARK = "data-inkmotion-region"

_URL = re.compile(r"url\(\s*['\"]?#([^'\")\s]+)['\"]?\s*\)")
_STYLE_CLIP = re.compile(r"(?:^|;)\s*clip-path\s*:\s*([^;]+)")


def _clip_reference(el: Any) -> str | None:
    """The id of the clip path ``el`` names (attribute, else its style), or None."""
    value = el.get("clip-path")
    if value is None:
        found = _STYLE_CLIP.search(el.get("style") or "")
        value = found.group(1) if found else None
    match = _URL.search(value or "")
    return match.group(1) if match else None


def _local(tag: Any) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def mark_clip_regions(root: Any) -> bool:
    """Step 1 of the module docstring on the ElementTree ``root``; returns whether any
    element named a clip path it could mark."""
    clips = {el.get("id"): el for el in root.iter() if _local(el.tag) == "clipPath"}
    parents = {child: parent for parent in root.iter() for child in parent}
    inside_clip = {el for clip in clips.values() for el in clip.iter()}
    marked = 0
    for el in list(root.iter()):
        ref = _clip_reference(el)
        clip = clips.get(ref) if ref else None
        if clip is None or el in inside_clip or el not in parents:
            continue
        if clip.get("clipPathUnits", "userSpaceOnUse").strip() != "userSpaceOnUse":
            continue
        marked += 1
        el.set(f"{CLIP_MARK}{marked}", "1")
        region = el.makeelement(el.tag[:-len(_local(el.tag))] + "g",
                                {REGION_MARK: str(marked)})
        if el.get("transform"):
            region.set("transform", el.get("transform"))
        inner = region.makeelement(region.tag, {})
        if clip.get("transform"):
            inner.set("transform", clip.get("transform"))
        for shape in clip:
            shape = copy.deepcopy(shape)
            for part in shape.iter():
                part.attrib.pop("id", None)  # a <use> elsewhere still finds the original
            inner.append(shape)
        region.append(inner)
        parent = parents[el]
        parent.insert(list(parent).index(el) + 1, region)
    return marked > 0


def region_of(el: Any) -> int | None:
    """The clip region a parsed svgelements shape outlines (step 1), or None."""
    value = getattr(el, "values", {}).get(REGION_MARK)
    return int(value) if value is not None else None


def clips_of(el: Any) -> list[int]:
    """The clip regions a parsed svgelements shape is to be cut by (step 1)."""
    return sorted(int(key[len(CLIP_MARK):]) for key in getattr(el, "values", {})
                  if key.startswith(CLIP_MARK) and key[len(CLIP_MARK):].isdigit())


def regions(outlines: dict[int, list[np.ndarray]]) -> dict[int, Any]:
    """Each region's shapely area: the union of the polygons of its closed outlines
    (polylines of 3 points or more; an outline that is not closed is closed)."""
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    areas = {}
    for n, lines in outlines.items():
        polygons = [Polygon(line[:, :2]).buffer(0) for line in lines if len(line) >= 3]
        areas[n] = unary_union([p for p in polygons if not p.is_empty]) if polygons else None
    return areas


def clip_polylines(lines: list[np.ndarray], area: Any) -> list[np.ndarray]:
    """The parts of ``lines`` (polylines (k, 2)) inside the shapely ``area`` (None: an
    empty clip path, nothing is drawn), each in its line's order and direction; a dot (a
    polyline of zero length) is kept when it lies inside."""
    from shapely.geometry import LineString, Point

    if area is None or area.is_empty:
        return []
    out: list[np.ndarray] = []
    for line in lines:
        xy = np.asarray(line, dtype=np.float64)[:, :2]
        if float(np.abs(np.diff(xy, axis=0)).sum()) == 0.0:
            if area.covers(Point(xy[0])):
                out.append(line)
            continue
        whole = LineString(xy)
        if area.covers(whole):
            out.append(line)
            continue
        inside = whole.intersection(area)
        pieces = [g for g in getattr(inside, "geoms", [inside])
                  if g.geom_type == "LineString" and not g.is_empty and g.length > 0]
        spans = []
        for piece in pieces:
            coords = np.asarray(piece.coords, dtype=np.float64)
            a, b = whole.project(Point(coords[0])), whole.project(Point(coords[-1]))
            if a > b:
                coords, a = coords[::-1], b
            spans.append((a, coords))
        joined: list[np.ndarray] = []
        for _, coords in sorted(spans, key=lambda s: s[0]):
            if joined and np.allclose(joined[-1][-1], coords[0], atol=1e-9):
                joined[-1] = np.vstack((joined[-1], coords[1:]))
            else:
                joined.append(coords)
        out.extend(joined)
    return out
