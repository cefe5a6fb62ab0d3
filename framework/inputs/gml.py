"""GML parsing: Graffiti Markup Language tags in XML (spec 1.0) and the 000000book JSON form,
read into traces (the 'gml' reader plugin wraps it).

Accepted inputs (the plugin picks them by file suffix ``.gml``, ``.json``, ``.jsonp``,
``.js``, or ``.xml`` whose root element is ``<gml>``):

- GML XML: ``<gml><tag><header><environment>…</environment></header><drawing><stroke>
  <pt><x/><y/>[<z/>][<t/>|<time/>]</pt>…</stroke>…</drawing>…</tag>…</gml>``. Element
  names are matched case-insensitively (``screenBounds`` and ``screenbounds`` both occur).
- The 000000book JSON form ``{"gml": {"tag": {"header": …, "drawing": {"stroke": […]}}}}``
  where any of tag / drawing / stroke / pt may be a list or a single object and numbers
  are usually strings; also that JSON wrapped as JSONP, ``callback({...});``.

Coordinates. GML points are normalised to 0..1 of the recording screen. Each point is
scaled by ``environment/screenBounds`` (x by its x, y by its y) so the aspect ratio of the
screen is restored; without screenBounds the scale is 1. GML's y axis points down on the
screen, like the canvas.

Up vector (convention of this reader). ``environment/up`` is the direction, *in the
recorded point coordinates*, that was "up" for the person drawing. The GML default and
by far the most common value is ``up = (0, -1, 0)``: up is −y, the ordinary y-down screen
orientation, and nothing is changed. Any other up vector means the device was held
rotated; the reader rotates the (screen-scaled) points about the origin by the angle
``θ = atan2(-1, 0) − atan2(up_y, up_x)`` so that ``up`` maps onto −y of the canvas, i.e.
the drawing stands upright. Concretely, with (x, y) the scaled point:

- ``up = (1, 0, 0)``  (θ = −90°):  (x, y) -> ( y, −x)
- ``up = (-1, 0, 0)`` (θ = +90°):  (x, y) -> (−y,  x)
- ``up = (0, 1, 0)``  (θ = 180°):  (x, y) -> (−x, −y)

so ±x up vectors swap the axes (with the sign that keeps the drawing unmirrored: a pure
rotation never mirrors). An up vector with no x/y component (e.g. ``(0, 0, 1)``) is
treated as the default. The translation after rotating is irrelevant because the
framework refits the traces to the canvas (:meth:`Traces.fit_to_canvas`).

Strokes with ``isdrawing="false"`` (pen moves without ink) are skipped; points without
both x and y (the spec allows bare pressure/rotation points) are skipped; ``z`` is
ignored. Times (``<t>`` or the older ``<time>``) are kept per stroke in
``Traces.meta["t"]`` (one float array per returned stroke), in the file's unit (seconds
or milliseconds: ``meta["time_unit"]`` when the caller declares it, else the evaluation
tells them apart). A few points without a time (at most :data:`FILLED_SHARE` of them,
each stroke keeping two) get theirs from their stroke's neighbours, by point index, and
``meta["times_filled"]`` counts them; with more, no stroke keeps times and
``meta["times_missing"]`` says how many points had none.
"""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from typing import Any

import numpy as np

from inkmotion.errors import InputError
from inkmotion.geometry.input_file import MAX_FILE_BYTES as DEFAULT_MAX_FILE_BYTES
from inkmotion.geometry.input_file import checked_input_file, reader_boundary
from inkmotion.geometry.traces import MAX_POINTS, Traces

#: files larger than this are refused before parsing (bytes)
MAX_FILE_BYTES = DEFAULT_MAX_FILE_BYTES

_JSONP = re.compile(r"^\s*[A-Za-z_$][\w$.]*\s*\(\s*(?P<body>.*?)\s*\)\s*;?\s*$", re.DOTALL)


class _Stroke:
    """One pen-down stroke while parsing: points (k, 2) in normalised units and times."""

    def __init__(self, points: list[tuple[float, float]], times: list[float | None]) -> None:
        self.points = points
        self.times = times


class _Tag:
    """One GML ``<tag>``: its screen bounds, up vector and strokes."""

    def __init__(self) -> None:
        self.bounds: tuple[float, float] = (1.0, 1.0)
        self.up: tuple[float, float] = (0.0, -1.0)
        self.strokes: list[_Stroke] = []
        self.points = 0  # points of its strokes so far (the limit's count)
        self.own_bounds = self.own_up = False  # given in this tag's environment


def read_gml(source: str, time_unit: str = "auto") -> Traces:
    """Read a GML file (XML, JSON or JSONP) into validated :class:`Traces`; ``time_unit``
    ("s", "ms" or "auto") is recorded as the time stamps' unit unless "auto"."""
    data = _read_bytes(source)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{source}: the file is not UTF-8 text; save it as UTF-8 GML.") from exc
    with reader_boundary(source, "GML", "check that it is a complete GML file."):
        traces = _to_traces(_parse_text(text, source), source)
    if time_unit != "auto" and "t" in traces.meta:
        traces.meta["time_unit"] = time_unit
    return traces


def _read_bytes(source: str) -> bytes:
    return checked_input_file(source, "a GML drawing", MAX_FILE_BYTES).read_bytes()


def _parse_text(text: str, source: str) -> list[_Tag]:
    """Dispatch on the first non-blank character: ``<`` is XML, anything else JSON(P)."""
    stripped = text.lstrip()
    if not stripped:
        raise InputError(f"{source}: the file is blank; give a GML file that holds a drawing.")
    if stripped.startswith("<"):
        return _parse_xml(stripped, source)
    return _parse_json(stripped, source)


# --- one walk for both forms -------------------------------------------------------------


class _Node:
    """A GML node of either form, so that one walk (:func:`_tag`) reads both. It wraps an XML
    element (names match case-insensitively and without namespace, as writers differ) or a
    JSON value (keys match as :func:`_key` does; a non-object has no children or values)."""

    def __init__(self, raw: Any) -> None:
        self.raw = raw

    def children(self, name: str) -> list[_Node]:
        """Every child called ``name``: matching elements, or the JSON list (or value) there."""
        if isinstance(self.raw, ET.Element):
            return [_Node(c) for c in self.raw if _lower(c.tag) == name.lower()]
        return [_Node(v) for v in _as_list(_key(self.raw, name))]

    def child(self, name: str) -> _Node | None:
        """The first child called ``name``, or None; an empty JSON value counts as missing, so
        an empty header environment falls back to the tag's own."""
        if isinstance(self.raw, ET.Element):
            found = self.children(name)
            return found[0] if found else None
        value = _key(self.raw, name)
        return _Node(value) if value else None

    def number(self, name: str, source: str) -> float | None:
        """The number in child ``name`` (text, JSON number or string); None if absent/blank."""
        if isinstance(self.raw, ET.Element):
            found = self.child(name)
            value = found.raw.text if found else None
        else:
            value = _key(self.raw, name)
        if value is None or (isinstance(value, str) and not value.strip()):
            return None
        return _number(value, name, source)

    def attr(self, name: str) -> Any:
        """Attribute ``name``: XML lower case or as given (``isDrawing``); JSON the key's value."""
        if isinstance(self.raw, ET.Element):
            return self.raw.get(name.lower(), self.raw.get(name))
        return _key(self.raw, name)


def _tag(node: _Node, source: str) -> _Tag:
    """One tag: bounds and up vector from its environment (in the header or, for some writers,
    the tag itself), then the pen-down strokes of every drawing."""
    tag = _Tag()
    header = node.child("header")
    env = (header.child("environment") if header else None) or node.child("environment")
    bounds = env.child("screenBounds") if env else None
    if bounds is not None:
        tag.bounds = _bounds(bounds.number("x", source), bounds.number("y", source), source)
        tag.own_bounds = True
    up = env.child("up") if env else None
    if up is not None:
        tag.up = _up(up.number("x", source), up.number("y", source))
        tag.own_up = True
    for drawing in node.children("drawing"):
        for stroke in drawing.children("stroke"):
            if _is_drawing(stroke.attr("isDrawing")):
                tag.strokes.append(_stroke(tag, stroke, source))
    return tag


def _stroke(tag: _Tag, node: _Node, source: str) -> _Stroke:
    """One stroke's points and ``<t>`` (or older ``<time>``) times, skipping points without
    both x and y; the point limit counts the tag's earlier strokes too."""
    points: list[tuple[float, float]] = []
    times: list[float | None] = []
    for pt in node.children("pt"):
        x, y = pt.number("x", source), pt.number("y", source)
        if x is None or y is None:
            continue
        t = pt.number("t", source)
        points.append((x, y))
        times.append(pt.number("time", source) if t is None else t)
    _check_count(tag, points, source)
    return _Stroke(points, times)


# --- XML ---------------------------------------------------------------------------------


def _parse_xml(text: str, source: str) -> list[_Tag]:
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputError(
            f"{source}: the GML is not well-formed XML ({exc}); fix the file."
        ) from exc
    if _lower(root.tag) != "gml":
        raise InputError(f"{source}: the root element is <{root.tag}>, not <gml>; give a GML file.")
    tags = [_tag(node, source) for node in _Node(root).children("tag")]
    if not tags:
        raise InputError(f"{source}: the GML has no <tag> element, so there is nothing to draw.")
    return _one_screen(tags)


def _one_screen(tags: list[_Tag]) -> list[_Tag]:
    """``tags`` where a tag with no screen bounds or up vector of its own takes those of the
    tag before it: the later tags of a file were recorded on the same screen (read at scale
    1, a second tag without a header shrank to a dot beside the first)."""
    for before, tag in zip(tags[:-1], tags[1:], strict=True):
        if not tag.own_bounds:
            tag.bounds, tag.own_bounds = before.bounds, before.own_bounds
        if not tag.own_up:
            tag.up, tag.own_up = before.up, before.own_up
    return tags


def _lower(tag: str) -> str:
    """Element name without namespace, lower case."""
    return tag.rsplit("}", 1)[-1].lower()


# --- JSON --------------------------------------------------------------------------------


def _parse_json(text: str, source: str) -> list[_Tag]:
    body = text
    if not text.startswith(("{", "[")):
        match = _JSONP.match(text)
        if match is None:
            raise InputError(
                f"{source}: the file is neither GML XML nor JSON/JSONP; give a GML file."
            )
        body = match.group("body")
    try:
        doc = json.loads(body)
    except json.JSONDecodeError as exc:
        raise InputError(
            f"{source}: the JSON is malformed or truncated ({exc.msg} at line {exc.lineno}); "
            "download the tag again."
        ) from exc
    gml = _key(doc, "gml") if isinstance(doc, dict) else None
    if gml is None and isinstance(doc, dict) and _key(doc, "tag") is not None:
        gml = doc
    if isinstance(gml, str) and gml.lstrip().startswith("<"):
        return _parse_xml(gml.lstrip(), source)
    if not isinstance(gml, dict):
        raise InputError(f'{source}: the JSON has no "gml" object; give a 000000book GML JSON.')
    tags = [_tag(_json_tag(node, source), source) for node in _Node(gml).children("tag")]
    if not tags:
        raise InputError(f"{source}: the GML has no tag, so there is nothing to draw.")
    return _one_screen(tags)


def _json_tag(node: _Node, source: str) -> _Node:
    """``node`` itself: a JSON tag must be an object to be walked."""
    if not isinstance(node.raw, dict):
        raise InputError(f"{source}: a GML tag is not an object; give a 000000book GML JSON.")
    return node


def _key(obj: Any, name: str) -> Any:
    """``obj[name]`` matched case-insensitively (also ``@name``), or None."""
    if not isinstance(obj, dict):
        return None
    for k, v in obj.items():
        if isinstance(k, str) and k.lower().lstrip("@_") == name.lower():
            return v
    return None


def _as_list(value: Any) -> list:
    if value is None:
        return []
    return value if isinstance(value, list) else [value]


# --- shared ------------------------------------------------------------------------------


def _number(value: Any, name: str, source: str) -> float:
    """A float from a GML value (number or numeric string); NaN is kept for validation."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise InputError(f"{source}: a <{name}> value is not a number; fix the file.")
    try:
        return float(value)
    except ValueError as exc:
        raise InputError(
            f"{source}: the <{name}> value {str(value)[:30]!r} is not a number; fix the file."
        ) from exc


def _is_drawing(flag: Any) -> bool:
    """GML ``isdrawing``: absent or anything but false/0/no means a pen-down stroke."""
    if flag is None:
        return True
    if isinstance(flag, bool):
        return flag
    return str(flag).strip().lower() not in ("false", "0", "no")


def _bounds(x: float | None, y: float | None, source: str) -> tuple[float, float]:
    """Screen bounds as a positive scale of both axes; when either is missing, zero or not
    finite, (1, 1): one axis scaled alone would squash the drawing flat. A negative one
    is refused (a screen held otherwise is the up vector's to say)."""
    for axis, value in (("x", x), ("y", y)):
        if value is not None and value < 0:
            raise InputError(
                f"{source}: its screenBounds {axis} is {value:g}, but a screen's size cannot "
                "be negative; correct it (the up vector, not the bounds, says which way the "
                "screen was held).")
    if all(v is not None and math.isfinite(v) and v > 0 for v in (x, y)):
        return float(x), float(y)  # type: ignore[arg-type]
    return 1.0, 1.0


def _up(x: float | None, y: float | None) -> tuple[float, float]:
    """The up vector's x/y; (0, -1) when missing, zero or not finite."""
    ux, uy = x or 0.0, y or 0.0
    if not (math.isfinite(ux) and math.isfinite(uy)) or math.hypot(ux, uy) < 1e-9:
        return 0.0, -1.0
    return ux, uy


def up_rotation(up: tuple[float, float]) -> np.ndarray:
    """2×2 rotation taking the up direction ``up`` onto −y (see the module docstring).

    θ = atan2(−1, 0) − atan2(up_y, up_x); R = [[cos θ, −sin θ], [sin θ, cos θ]], rounded
    so the axis-aligned cases are exact permutations.
    """
    theta = math.atan2(-1.0, 0.0) - math.atan2(up[1], up[0])
    c, s = math.cos(theta), math.sin(theta)
    return np.round(np.array([[c, -s], [s, c]]), 15)


def _check_count(tag: _Tag, points: list, source: str) -> None:
    """Count ``points`` into the tag's total (a running sum: summing every earlier stroke
    again for each new one took minutes on 100 000 strokes) and refuse past the limit."""
    tag.points += len(points)
    if tag.points > MAX_POINTS:
        raise InputError(
            f"{source}: more than {MAX_POINTS} points, the limit; "
            "simplify the drawing or split it into several inputs."
        )


#: the largest share of a drawing's points whose missing time stamps are filled in from
#: their neighbours (module docstring); with more the recording has no times
FILLED_SHARE = 0.1


def _filled_times(times: list[np.ndarray]) -> tuple[list[np.ndarray] | None, int]:
    """``times`` (one array per stroke, NaN where a point has none) with the gaps filled
    from each stroke's stamped points by point index (ends: the nearest stamp), and how
    many were missing; None when more than :data:`FILLED_SHARE` are, or a stroke with a
    gap has fewer than two stamps."""
    missing = sum(int(np.count_nonzero(~np.isfinite(t))) for t in times)
    total = sum(len(t) for t in times)
    if not missing:
        return times, 0
    filled = []
    for t in times:
        known = np.isfinite(t)
        if known.all():
            filled.append(t)
            continue
        if missing > FILLED_SHARE * total or int(known.sum()) < 2:
            return None, missing
        index = np.arange(len(t))
        filled.append(np.interp(index, index[known], t[known]))
    return filled, missing


#: how long a tap of the pen (a stroke of one point, drawn as a dab) lasts in the
#: recording's time: one frame of a 60-Hz capture
TAP_SECONDS = 1 / 60


def _drop_repeats(points: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop consecutive repeated points (as :meth:`Traces.validated` does) keeping times
    aligned; non-finite points are kept so validation reports them."""
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = ~np.all(np.abs(np.diff(points, axis=0)) <= 1e-12, axis=1)
    return points[keep], times[keep]


def _to_traces(tags: list[_Tag], source: str) -> Traces:
    strokes: list[np.ndarray] = []
    times: list[np.ndarray] = []
    for tag in tags:
        rot = up_rotation(tag.up)
        scale = np.array(tag.bounds)
        for s in tag.strokes:
            if not s.points:
                continue
            pts = (np.asarray(s.points, dtype=np.float64) * scale) @ rot.T  # (k, 2)
            t = np.array([np.nan if v is None else v for v in s.times], dtype=np.float64)
            pts, t = _drop_repeats(pts, t)
            if len(pts) == 1:  # a tap: drawn as a dab (Traces.validated), one frame long
                t = np.append(t, t[0] + TAP_SECONDS)
            strokes.append(pts)
            times.append(t)
    if not strokes and not any(s.points for tag in tags for s in tag.strokes):
        raise InputError(
            f"{source}: the GML has no pen-down points, so there is nothing to draw; "
            "check that the file holds a drawing."
        )
    meta: dict = {"format": "gml", "tags": len(tags)}
    traces = Traces(strokes, source=source, meta=meta).validated()
    if len(traces.strokes) == len(times):
        filled, missing = _filled_times(times)
        if filled is not None:
            traces.meta["t"] = filled
        if missing and filled is not None:
            traces.meta["times_filled"] = missing
        elif missing and any(np.isfinite(t).any() for t in times):
            traces.meta["times_missing"] = missing
            traces.meta["points"] = sum(len(t) for t in times)
    return traces
