"""SVG parsing: vector paths and basic shapes into polylines, one stroke per subpath (the
'svg' reader plugin wraps it).

Parsing, units, ``viewBox`` and nested ``transform`` attributes are handled by
`svgelements <https://github.com/meerk40t/svgelements>`_ (``SVG.parse`` reifies every
transform into the geometry). Every visible shape (``path``, ``polyline``, ``polygon``,
``line``, ``rect``, ``circle``, ``ellipse``, shapes reached through ``use``) becomes a
path (a shape that paints nothing, no stroke or fill or an opacity of 0, is left out, and
so is paper: a white fill with no stroke, and a filled background behind all the lines);
each subpath (a ``M`` … run) becomes one stroke. Closed subpaths end at their start point.
A drawing whose every shape is a filled area with no stroke (a logo, text turned into
paths) is drawn along its outlines, and ``meta["notes"]`` says so and how to fit the
centre lines instead (its picture, traced); it names text that is still text and embedded
pictures too, which are not drawn. Curves (quadratic, cubic, elliptical arcs)
are flattened by adaptive subdivision until every interval's midpoint lies within ``tol``
of its chord, where ``tol`` is ``FLATNESS`` times the drawing's bounding-box diagonal
(scale-free, so the same file at any size flattens to the same polyline shape).
Coordinates are SVG user units, y down.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from inkmotion.errors import InputError
from inkmotion.geometry.input_file import MAX_FILE_BYTES as DEFAULT_MAX_FILE_BYTES
from inkmotion.geometry.input_file import checked_input_file, reader_boundary
from inkmotion.geometry.traces import MAX_POINTS, Traces
from inkmotion.inputs.svg_clip import (
    clip_polylines,
    clips_of,
    mark_clip_regions,
    region_of,
    regions,
)

#: files larger than this are refused before parsing (bytes)
MAX_FILE_BYTES = DEFAULT_MAX_FILE_BYTES
#: flattening tolerance as a fraction of the drawing's bounding-box diagonal
FLATNESS = 2e-4
#: deepest subdivision per curve segment (2**MAX_DEPTH intervals at most)
MAX_DEPTH = 12
#: the class of an SVG's annotations that are not part of the drawing: the arrows and
#: numbers ``inkmotion trace`` writes beside each stroke, so that its strokes.svg, checked
#: or corrected, is fitted as the strokes alone
ANNOTATION_CLASS = "inkmotion-order"

#: a filled shape with no stroke whose every channel is at least this (0-255) is the
#: paper's colour (white, or nearly), not ink
PAPER_LEVEL = 240


def read_svg(source: str) -> Traces:
    """Read an SVG file into validated :class:`Traces` in user units (y down)."""
    path = checked_input_file(source, "SVG paths", MAX_FILE_BYTES)
    with reader_boundary(source, "SVG", "check that it is a complete, well-formed SVG file."):
        import svgelements as se

        document = _document(path, source)
        try:
            parsed = se.SVG.parse(document)
        except Exception as exc:
            bad = _bad_path_data(exc, se)
            if bad is None:
                raise
            raise InputError(f"{source}: a path's data is not valid SVG path data "
                             f"(d=\"{bad[:40]}\"); fix or remove that path.") from exc
        if not isinstance(parsed, se.SVG):  # svgelements gives what it found: no <svg> root
            raise InputError(f"{source}: the file is XML but not an SVG (its root is not "
                             f"<svg>); export the drawing as an SVG.")
        shown = [el for el in _shown(parsed) if not _annotation(el)]
        outlines = [el for el in shown if isinstance(el, se.Shape) and region_of(el)]
        shown = [el for el in shown if region_of(el) is None]
        painted = [el for el in shown if isinstance(el, se.Shape) and _painted(el)]
        hidden = not painted and any(isinstance(el, se.Shape) for el in shown)
        shapes, paper, backgrounds = _ink(painted)
        strokes = _flatten(shapes, se, source, outlines)
        filled = bool(shapes) and all(  # filled areas with no stroke: a logo's export
            el.fill is not None and el.fill.value is not None
            and (el.stroke is None or el.stroke.value is None) for el in shapes)
        texts = sum(isinstance(el, se.Text) for el in shown)  # text that is still text
        images = sum(isinstance(el, se.Image) for el in shown)  # embedded pictures
    if not strokes and not hidden and _any_hidden_shape(path, source, shown):
        raise InputError(
            f"{source}: every shape of the SVG is hidden (display: none or visibility: "
            "hidden, a hidden layer), so there is nothing to draw; show the layer with the "
            "lines to draw."
        )
    if not strokes and hidden:
        raise InputError(
            f"{source}: every shape of the SVG is invisible (no stroke or fill, or an "
            "opacity of 0), so there is nothing to draw; give the lines to draw a stroke "
            "colour."
        )
    if not strokes and any(isinstance(el, se.Shape) for el in shown):
        raise InputError(
            f"{source}: the SVG's paths and shapes draw nothing (a moveto alone, a shape "
            "of zero size, a path wholly outside its clip path), so there is nothing to "
            "draw; check that it holds the drawing."
        )
    if not strokes:
        raise InputError(
            f"{source}: the SVG holds no paths or shapes, so there is nothing to draw; "
            "convert text and images to paths first."
        )
    meta: dict[str, Any] = {"format": "svg"}
    notes = []
    if paper:
        which = f"{paper} white filled shapes" if paper > 1 else "white filled shape"
        notes.append(f"its {which} (the paper's colour: a page, a highlight) "
                     f"{'are' if paper > 1 else 'is'} not drawn")
    if backgrounds:
        notes.append("its background (a filled shape with no outline behind all of its "
                     "lines) is not drawn")
    if filled:
        notes.append("its shapes are filled areas with no stroke, so the motion follows "
                     "their outlines; to draw their centre lines instead, export the "
                     "drawing as a PNG and give that")
    if texts or images:  # shown, but not drawn
        shown = " and ".join(f"{n} {what}{'s' if n > 1 else ''}" for what, n in
                             (("text element", texts), ("image", images)) if n)
        advice = (["convert its text to paths to draw it (in Inkscape: Path > Object to "
                   "Path)"] if texts else []) + (
            ["give an embedded picture as a file of its own to trace it"] if images else [])
        notes.append(f"its {shown} {'is' if texts + images == 1 else 'are'} not drawn, "
                     f"only its paths and shapes; {' and '.join(advice)}")
    if notes:
        meta["notes"] = notes
    return Traces(strokes, source=source, meta=meta).validated()


def _document(path: Any, source: str) -> Any:
    """What to parse: the file's bytes, unpacked when they are gzip-compressed (an
    ``.svgz``, as Inkscape saves it, or such data under another name)."""
    import gzip
    import io

    with open(path, "rb") as f:
        compressed = f.read(2) == b"\x1f\x8b"
    if compressed:
        with gzip.open(path, "rb") as f:
            data = f.read(MAX_FILE_BYTES + 1)
        if len(data) > MAX_FILE_BYTES:
            raise InputError(f"{source}: unpacked, the SVG is more than the "
                             f"{MAX_FILE_BYTES // 2**20} MB limit; simplify the drawing or "
                             f"split it.")
    else:
        data = Path(path).read_bytes()
    _refuse_blowups(data, source)
    if (b"<symbol" not in data and b'%"' not in data and b"%'" not in data
            and b"<style" not in data and b"<switch" not in data
            and b"clip-path" not in data):
        return io.BytesIO(data)  # read once: svgelements parses these bytes
    return io.BytesIO(_as_svg_means(data))


#: the longest attribute value the reader parses (bytes): the XML parser's time grows with
#: the square of a value's length (a 30-MB attribute took minutes)
MAX_ATTRIBUTE_BYTES = 4 * 2**20
#: the most elements a document may expand to through its ``<use>`` references (each
#: ``<use>`` drawing a copy of what it references: ten of ten of ten … is a billion)
MAX_EXPANDED = 1_000_000


def _refuse_blowups(data: bytes, source: str) -> None:
    """Refuse, before svgelements parses it, an SVG whose parse would hang or exhaust the
    memory: an attribute value over :data:`MAX_ATTRIBUTE_BYTES`, or ``<use>`` references
    that expand to more than :data:`MAX_EXPANDED` elements (or reference themselves)."""
    for quote in (b'"', b"'"):
        start = data.find(b"=" + quote)
        while start != -1:
            end = data.find(quote, start + 2)
            if end == -1:
                break
            if end - start > MAX_ATTRIBUTE_BYTES:
                raise InputError(f"{source}: an attribute of {(end - start) / 2**20:.0f} MB is "
                                 f"more than the {MAX_ATTRIBUTE_BYTES // 2**20} MB the reader "
                                 "takes; simplify the drawing (a path of millions of points?).")
            start = data.find(b"=" + quote, end + 1)
    if b"<use" not in data:
        return
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(data)
    except ET.ParseError:
        return  # svgelements says what is wrong with it
    by_id = {el.get("id"): el for el in root.iter() if el.get("id")}
    sizes: dict[int, int] = {}

    def size(el: Any, seen: frozenset[int]) -> int:
        key = id(el)
        if key in seen:
            raise InputError(f"{source}: a <use> refers, through others, to itself; remove "
                             "the loop.")
        if key not in sizes:
            total, seen = 1, seen | {key}
            for child in el:
                total += size(child, seen)
            if isinstance(el.tag, str) and el.tag.rsplit("}", 1)[-1] == "use":
                href = next((v for k, v in el.attrib.items() if k.endswith("href")), "")
                target = by_id.get(href.lstrip("#"))
                if target is not None:
                    total += size(target, seen)
            sizes[key] = min(total, MAX_EXPANDED + 1)
        return sizes[key]

    if size(root, frozenset()) > MAX_EXPANDED:
        raise InputError(f"{source}: its <use> references expand to more than "
                         f"{MAX_EXPANDED:,} elements; give the drawing with fewer copies.")


#: a shape's length attributes that are shares of the viewport's width, and of its height
_ACROSS = ("x", "cx", "rx", "x1", "x2", "width")
_DOWN = ("y", "cy", "ry", "y1", "y2", "height")


def _as_svg_means(data: bytes) -> bytes:
    """The SVG ``data`` with what svgelements (1.9) reads otherwise made explicit: a
    percentage length of a shape as user units of the root viewport (it takes a share of
    the height for x and of the width for y); CSS rules whose selectors nest
    (:func:`_apply_nested_css`); a ``<switch>`` as its one child drawn
    (:func:`_resolve_switches`); clip paths marked to be applied
    (:func:`inkmotion.inputs.svg_clip.mark_clip_regions`); a ``<symbol>`` drawn only where
    a ``<use>`` places it (moved into ``<defs>``), and a ``<use>`` with a width and height
    fitting the symbol's ``viewBox`` into them (preserveAspectRatio's default, xMidYMid
    meet), as a transform."""
    import xml.etree.ElementTree as ET

    svg_ns, xlink = "http://www.w3.org/2000/svg", "http://www.w3.org/1999/xlink"
    ET.register_namespace("", svg_ns)
    ET.register_namespace("xlink", xlink)
    root = ET.fromstring(data)
    changed = (_resolve_percentages(root) | _apply_nested_css(root)
               | _resolve_switches(root) | mark_clip_regions(root))
    symbols = {}
    for parent in root.iter():
        for child in list(parent):
            if child.tag in (f"{{{svg_ns}}}symbol", "symbol"):
                symbols[child.get("id")] = child
                if parent.tag not in (f"{{{svg_ns}}}defs", "defs"):
                    parent.remove(child)
                    defs = ET.SubElement(root, f"{{{svg_ns}}}defs")
                    defs.append(child)
    for use in root.iter(f"{{{svg_ns}}}use"):
        ref = (use.get(f"{{{xlink}}}href") or use.get("href") or "").lstrip("#")
        symbol = symbols.get(ref)
        box = symbol.get("viewBox") if symbol is not None else None
        if box is None or use.get("width") is None or use.get("height") is None:
            continue
        try:
            bx, by, bw, bh = (float(v) for v in box.replace(",", " ").split())
            w, h = float(use.get("width", "")), float(use.get("height", ""))
            x, y = float(use.get("x", "0")), float(use.get("y", "0"))
        except ValueError:  # units or percentages: left as they are
            continue
        if bw <= 0 or bh <= 0:
            continue
        k = min(w / bw, h / bh)
        dx, dy = x + (w - bw * k) / 2 - bx * k, y + (h - bh * k) / 2 - by * k
        use.set("transform", f"{use.get('transform', '')} translate({dx:g} {dy:g}) "
                             f"scale({k:g})".strip())
        for name in ("x", "y", "width", "height"):
            use.attrib.pop(name, None)
    # unchanged, the file as it was (written again, it would lose comments and CDATA)
    return ET.tostring(root) if changed or symbols else data


#: the language a ``<switch>`` picks its child for (``systemLanguage``): the same choice
#: on every machine, whatever its locale
SWITCH_LANGUAGE = "en"


def _resolve_switches(root: Any) -> bool:
    """Each ``<switch>`` of ``root`` made a group of the one child a viewer draws: the
    first whose conditions hold, for a reader that supports no extension
    (``requiredExtensions``, e.g. Illustrator's private data beside its drawing) and reads
    :data:`SWITCH_LANGUAGE` (``systemLanguage``); ``requiredFeatures`` hold (SVG 2).
    svgelements draws every child. Returns whether any switch was found."""

    def holds(el: Any) -> bool:
        if (el.get("requiredExtensions") or "").strip():
            return False
        languages = el.get("systemLanguage")
        if languages is None:
            return True
        return any(lang.strip().lower().split("-")[0] == SWITCH_LANGUAGE
                   for lang in languages.split(","))

    found = False
    for switch in list(root.iter()):
        if not isinstance(switch.tag, str) or switch.tag.rsplit("}", 1)[-1] != "switch":
            continue
        found = True
        children = [c for c in switch if isinstance(c.tag, str)]
        chosen = next((c for c in children if holds(c)), None)
        for child in children:
            if child is not chosen:
                switch.remove(child)
        switch.tag = switch.tag[:-len("switch")] + "g"
    return found


#: one compound selector of a CSS rule: a tag, classes and an id, each optional
_COMPOUND = re.compile(r"^(?P<tag>[A-Za-z][\w-]*|\*)?(?P<rest>(?:[.#][\w-]+)*)$")


def _apply_nested_css(root: Any) -> bool:
    """The declarations of the ``<style>`` rules whose selectors nest (``.sketch path``,
    ``g.ink > path``: svgelements applies only rules of one compound selector) written
    into the style of the elements they select, before the element's own (which wins, as
    CSS has it). Selectors of other forms (attributes, pseudo-classes) are left alone.
    Whether any element was given a declaration."""
    local = lambda tag: str(tag).rsplit("}", 1)[-1]  # noqa: E731
    sheets = " ".join(el.text or "" for el in root.iter() if local(el.tag) == "style")
    rules = re.findall(r"([^{}]+)\{([^{}]*)\}", re.sub(r"/\*.*?\*/", "", sheets, flags=re.S))
    parents = {child: parent for parent in root.iter() for child in parent}
    changed = False

    def matches(el: Any, compound: str) -> bool:
        found = _COMPOUND.match(compound)
        if found is None:
            return False
        tag, rest = found.group("tag"), found.group("rest")
        classes = set((el.get("class") or "").split())
        return ((tag in (None, "*") or local(el.tag) == tag)
                and all(c[1:] in classes if c[0] == "." else el.get("id") == c[1:]
                        for c in re.findall(r"[.#][\w-]+", rest)))

    def selects(el: Any, parts: list[str]) -> bool:
        if not matches(el, parts[-1]):
            return False
        if len(parts) == 1:
            return True
        combinator, rest = parts[-2], parts[:-2]
        up = parents.get(el)
        if combinator == ">":
            return up is not None and selects(up, rest)
        while up is not None:
            if selects(up, rest):
                return True
            up = parents.get(up)
        return False

    for selectors, body in rules:
        declarations = body.strip().rstrip(";")
        for selector in selectors.split(","):
            tokens = re.sub(r"\s*>\s*", " > ", selector.strip()).split()
            if len(tokens) < 2 or not declarations:
                continue  # one compound: svgelements applies it
            chain: list[str] = []  # compounds with their combinators, " " or ">", between
            for t in tokens:
                if t != ">" and chain and chain[-1] != ">":
                    chain.append(" ")
                chain.append(t)
            for el in root.iter():
                if selects(el, chain):
                    own = el.get("style", "")
                    el.set("style", f"{declarations};{own}" if own else declarations)
                    changed = True
    return changed


def _resolve_percentages(root: Any) -> bool:
    """Percentage lengths of the shapes under ``root`` (an ``<svg>`` element) as numbers:
    shares of its viewBox's width (x-like) or height (y-like), or of their diagonal over
    √2 (``r``); without a numeric viewBox, width and height, left as they are. Whether
    any was."""
    import math

    box = (root.get("viewBox") or "").replace(",", " ").split()
    try:
        w, h = (float(box[2]), float(box[3])) if len(box) == 4 else (
            float(root.get("width", "")), float(root.get("height", "")))
    except ValueError:
        return False
    changed = False
    for el in root.iter():
        for name, value in list(el.attrib.items()):
            if not value.strip().endswith("%") or el is root:
                continue
            share = float(value.strip()[:-1]) / 100 if _is_number(value.strip()[:-1]) else None
            if share is None:
                continue
            whole = (w if name in _ACROSS else h if name in _DOWN
                     else math.hypot(w, h) / math.sqrt(2) if name == "r" else None)
            if whole is not None:
                el.set(name, f"{share * whole:g}")
                changed = True
    return changed


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _bad_path_data(exc: BaseException, se: Any) -> str | None:
    """The ``d`` of the path whose data svgelements failed on while raising ``exc`` (a
    frame of its ``Path.parse`` in the traceback), or None when the failure lies
    elsewhere."""
    tb = exc.__traceback__
    while tb is not None:
        frame = tb.tb_frame
        if frame.f_code.co_name == "parse" and isinstance(frame.f_locals.get("self"), se.Path):
            return str(frame.f_locals.get("pathdef", ""))
        tb = tb.tb_next
    return None


def _any_hidden_shape(path: Any, source: str, shown: list[Any]) -> bool:
    """Whether the SVG holds more shapes than the ``shown`` ones (parsed again, with what
    ``display: none`` hides)."""
    import svgelements as se

    every = se.SVG.parse(_document(path, source), parse_display_none=True).elements()
    return sum(isinstance(el, se.Shape) and region_of(el) is None and not _annotation(el)
               for el in every) > sum(
        isinstance(el, se.Shape) for el in shown)


def _annotation(el: Any) -> bool:
    """Whether ``el`` is one of the annotations :data:`ANNOTATION_CLASS` marks."""
    return ANNOTATION_CLASS in str(getattr(el, "values", {}).get("class", "")).split()


def _shown(svg: Any) -> list[Any]:
    """The elements of ``svg`` whose ``visibility`` is neither hidden nor collapsed
    (svgelements already leaves out ``display: none`` and ``defs``); a shape among them
    is drawn when it paints something (:func:`_painted`)."""
    return [el for el in svg.elements()
            if str(getattr(el, "values", {}).get("visibility", "visible")) not in (
                "hidden", "collapse")]


def _ink(shapes: list[Any]) -> tuple[list[Any], int, int]:
    """The painted ``shapes`` that are the drawing, and how many were left out as paper:
    filled shapes with no stroke in white (each channel at least :data:`PAPER_LEVEL`, as
    a page or a matplotlib figure's patch is exported), unless nothing else is painted;
    then, when some shape is stroked (line art), a filled shape with no stroke whose box
    holds every stroked shape's box (a background rectangle, whatever its colour)."""
    def unstroked_fill(el: Any) -> bool:
        return _filled(el) and not _stroked(el)

    def white(el: Any) -> bool:
        return min(el.fill.red, el.fill.green, el.fill.blue) >= PAPER_LEVEL

    ink = [el for el in shapes if not (unstroked_fill(el) and white(el))] or shapes
    paper = len(shapes) - len(ink)
    lines = [el.bbox() for el in ink if _stroked(el)]
    lines = [b for b in lines if b is not None]
    if not lines:
        return ink, paper, 0
    lo = np.min([b[:2] for b in lines], axis=0)
    hi = np.max([b[2:] for b in lines], axis=0)
    slack = 1e-6 * max(float(np.hypot(*(hi - lo))), 1.0)

    def behind_everything(el: Any) -> bool:
        box = el.bbox() if unstroked_fill(el) else None
        return box is not None and bool((np.asarray(box[:2]) <= lo + slack).all()
                                         and (np.asarray(box[2:]) >= hi - slack).all())

    drawing = [el for el in ink if not behind_everything(el)]
    return drawing, paper, len(ink) - len(drawing)


def _stroked(shape: Any) -> bool:
    """Whether ``shape`` has a visible stroke (a colour, not fully transparent, of a width
    above 0)."""
    stroke = shape.stroke
    return (stroke is not None and stroke.value is not None and stroke.alpha > 0
            and (shape.stroke_width is None or shape.stroke_width > 0))


def _filled(shape: Any) -> bool:
    """Whether ``shape`` has a visible fill (a colour, not fully transparent)."""
    fill = shape.fill
    return fill is not None and fill.value is not None and fill.alpha > 0


def _painted(shape: Any) -> bool:
    """Whether ``shape`` paints anything: an opacity above 0, and a stroke (a colour, not
    fully transparent, of a width above 0) or a fill (a colour, not fully transparent).
    A shape with neither, a construction line or a hidden guide, is not part of the
    drawing."""
    try:
        if float(shape.values.get("opacity", 1.0)) <= 0:
            return False
    except (TypeError, ValueError):
        pass  # an opacity that is not a number: as if it were not given
    # a line has no area: its fill (black by default) paints nothing
    return _stroked(shape) or (_filled(shape) and type(shape).__name__ != "SimpleLine")


def _flatten(shapes: list[Any], se: Any, source: str,
             outlines: list[Any] | None = None) -> list[np.ndarray]:
    """The ``shapes`` that are drawn (shown, :func:`_shown`, and painted,
    :func:`_painted`) as polylines (one per subpath), each cut to the clip regions it is
    marked with, whose shapes are ``outlines`` (:mod:`inkmotion.inputs.svg_clip`)."""
    paths, regions_of = [], []
    for el in shapes:
        # abs: the transform applied to the segments themselves (a shape that cannot carry
        # it, a circle in a rotated group, keeps it aside, unapplied, as a matrix)
        path = abs(el if isinstance(el, se.Path) else se.Path(el))
        if len(path) == 0:
            continue
        paths.append(path)
        regions_of.append(clips_of(el))
    if not paths:
        return []
    boxes = [p.bbox() for p in paths]
    boxes = [b for b in boxes if b is not None]
    if not boxes:
        return []
    lo = np.min([b[:2] for b in boxes], axis=0)
    hi = np.max([b[2:] for b in boxes], axis=0)
    tol = FLATNESS * max(float(np.hypot(*(hi - lo))), 1e-9)
    areas = _clip_areas(outlines or [], se, tol) if any(regions_of) else {}
    strokes: list[np.ndarray] = []
    count = 0
    for path, clips in zip(paths, regions_of, strict=True):
        lines = _path_strokes(path, se, tol)
        for n in clips:
            lines = clip_polylines(lines, areas.get(n))
        for stroke in lines:
            count += len(stroke)
            if count > MAX_POINTS:
                raise InputError(
                    f"{source}: more than {MAX_POINTS} points after flattening curves, the "
                    "limit; simplify the drawing or split it into several inputs."
                )
            strokes.append(stroke)
    return strokes


def _clip_areas(outlines: list[Any], se: Any, tol: float) -> dict[int, Any]:
    """Each clip region's area (:func:`inkmotion.inputs.svg_clip.regions`) from the
    parsed shapes that outline it."""
    lines: dict[int, list[np.ndarray]] = {}
    for el in outlines:
        path = abs(el if isinstance(el, se.Path) else se.Path(el))
        lines.setdefault(region_of(el), []).extend(_path_strokes(path, se, tol))
    return regions(lines)


def _path_strokes(path: Any, se: Any, tol: float) -> list[np.ndarray]:
    """One polyline per subpath of ``path``; curves subdivided to tolerance ``tol``."""
    strokes: list[np.ndarray] = []
    current: list[np.ndarray] = []
    start: np.ndarray | None = None

    def finish() -> None:
        if len(current) > 1:  # a moveto alone draws nothing; a zero-length segment, a dot
            strokes.append(np.vstack(current))

    for seg in path:
        if isinstance(seg, se.Move):
            finish()
            start = np.array([[seg.end.x, seg.end.y]], dtype=np.float64)
            current = [start]
            continue
        if seg.start is None or seg.end is None:
            continue
        if not current:  # a path without a leading M: start where the segment starts
            start = np.array([[seg.start.x, seg.start.y]], dtype=np.float64)
            current = [start]
        if isinstance(seg, (se.Line, se.Close)):
            current.append(np.array([[seg.end.x, seg.end.y]], dtype=np.float64))
        else:
            current.append(flatten_segment(_sampler(seg), tol)[1:])
    finish()
    return strokes


def _sampler(seg: Any) -> Any:
    """``t array -> (n, 2) points`` for an svgelements segment (its ``point`` is scalar-safe
    only: the vectorised form fails under numpy 2)."""

    def point(ts: np.ndarray) -> np.ndarray:
        out = np.empty((len(ts), 2), dtype=np.float64)
        for i, t in enumerate(ts):
            p = seg.point(float(t))
            out[i] = (p.x, p.y)
        return out

    return point


def flatten_segment(point: Any, tol: float, depth: int = MAX_DEPTH) -> np.ndarray:
    """Sample a curve ``point(t)``, t ∈ [0, 1], as a polyline within ``tol`` of it.

    Starts from 8 uniform intervals (so S-curves and full arcs are not mistaken for their
    chord) and halves every interval whose midpoint is farther than ``tol`` from its
    chord, at most ``depth`` times. ``point`` maps an array of t to (n, 2) points.
    Returns (k, 2) including both ends.
    """
    ts = np.linspace(0.0, 1.0, 9)
    for _ in range(depth):
        pts = np.asarray(point(ts), dtype=np.float64)  # (n, 2)
        mids_t = (ts[:-1] + ts[1:]) / 2.0
        mids = np.asarray(point(mids_t), dtype=np.float64)  # (n-1, 2)
        a, b = pts[:-1], pts[1:]
        chord = b - a
        length = np.hypot(chord[:, 0], chord[:, 1])
        rel = mids - a
        cross = np.abs(chord[:, 0] * rel[:, 1] - chord[:, 1] * rel[:, 0])
        dist = np.where(
            length > 1e-12, cross / np.maximum(length, 1e-12), np.hypot(rel[:, 0], rel[:, 1])
        )
        split = dist > tol
        if not np.any(split):
            return pts
        ts = np.sort(np.concatenate([ts, mids_t[split]]))
    return np.asarray(point(ts), dtype=np.float64)
