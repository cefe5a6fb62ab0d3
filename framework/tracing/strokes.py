"""Strokes of a line drawing from its ink mask: centrelines, a stroke graph, and strokes
formed, directed and ordered the way a hand draws them.

1. **Centrelines**: the mask's skeleton (:func:`skimage.morphology.skeletonize`; a piece
   of ink its thinning erases, as Zhang's thinning erases a thin line at 45°, thinned
   again by Lee's method, :func:`thinned`) as a graph of paths between tips and
   junctions (:func:`skeleton_paths`: scikit-image's pixel graph, split into paths as
   :class:`skan.Skeleton` splits it); the ink's radius along it is the distance transform
   (OpenCV's, exact) less half a pixel.
2. **Graph**: junction pixels joined by a path shorter than :data:`MERGE` ink radii are
   one junction (a crossing skeletonises into two forks a few pixels apart), and so are two
   forks further apart whose arms read as two lines crossing at a shallow angle
   (:data:`CROSSING_REACH`: a script l's loop); a branch from a junction to a tip
   shorter than :data:`SPUR` × the junction's radius (+1 px) is a spur of the ink's
   outline, not a stroke, and is dropped, unless its tip's ink reaches out of the
   junction's (a stroke's end just past where thick strokes merge; not on ruled paper,
   where a tip :data:`BURR` thin on a ruled line is the line's burr beside a stroke) or
   it is the point of a cusp:
   where a branch from a tip meets a fork whose other two arms close in at an inner
   angle under :data:`CUSP`, it is drawn out and back, however short (a narrow V's arms
   merge in the ink near its point, so the skeleton forks well before the point). Every
   tip is carried on to where its ink ends less its radius (:func:`_extend_tips`:
   thinning stops short of a stroke's end, most of all at a cusp's point), and the
   smoothing keeps a cusp's point where it is.
3. **Strokes**: at every junction the branch ends are paired straightest first, a pair
   taken while it bends by less than :data:`STRAIGHT` (a stroke goes straight through a
   crossing), then the ends left are paired, straightest first, while they bend by less
   than :data:`TURN` (a hand turns at a corner, even one as sharp as an R's leg leaving
   its bowl, rather than lift the pen; a sharper reversal at a junction, a hairpin, is
   where one stroke ends and another begins); a junction of two ends always joins them.
   Paired branches chain into strokes; a chain that comes back to its start is a loop.
   At a junction a chain passes through, the skeleton's wobble is cut out (the points
   within the junction's radius) and the two sides joined.
4. **Direction and order**: an open stroke begins at the end a writer begins at: the top
   one (strokes are pulled down) unless the stroke is nearly level, then the left one
   (smaller :data:`ACROSS_WEIGHT` · x + y); a loop begins at its top and runs
   counter-clockwise on the page, as the Latin script's o, and so does a loop a stroke
   runs on its way (an o or an e on a word's line: either way round joins the same two
   passes through its junction), unless it hangs from its junction (a g's tail) or the
   stroke runs straight on through the junction only the way it is (an R's bowl). A
   loop drawn with a gap or an overshoot between its ends (:func:`_loop_with_gap`) runs
   counter-clockwise too, unless its ends lie at its bottom: then clockwise, so that it
   sets off leftwards either way: of the 76 such strokes in 70 people's Quick, Draw!
   doodles, 69 run so, 56 counter-clockwise, and 30 from their top end (the open stroke's
   rule).
   Strokes are ordered in lines, top to bottom, each line left to right (by the stroke's
   left edge); strokes are in one line when the middle halves of their ink's heights
   overlap (:data:`CORE_TRIM`; the ink's, so a level bar, a t's, is as tall as its pen).
   Within a line, strokes one above the other over most of the
   wider one's width (:data:`COLUMN`) are a column, drawn top to bottom: the parts of
   one character stacked (an a's hook above its bowl), while a dot or a bar over a
   wider stroke keeps its place by its left edge. Small marks above a line's end (a
   kana's voicing marks), or dots each over a stem no wider than :data:`STEM` of it (an
   i's, a j's), a line of their own by their height, are drawn in the line below them,
   after what they mark (:func:`_marks_joined`); further out (a writer's dot beside a
   tag) or over the line's start, they come first.
5. **Dots**: ink that no stroke passes through, or only a stroke no longer than the blob
   is wide, is a dab, a stroke of two points across the blob, when it is at least as big
   as a dab of the drawing's pen; smaller specks (and any stroke within one) are noise
   and are dropped.

Coordinates: x, y in the picture's pixels, pixel centres at half-integers (the renderer's
convention); each stroke (k, 3) with its radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: junctions joined by a branch shorter than this × their radius (+1.5 px) are one: two
#: strokes crossing at an angle θ skeletonise into two forks about 2r/tan(θ/2) apart
MERGE = 2.5
#: two forks joined by a branch shorter than this × their radius (+1.5 px) are one crossing
#: when their arms read as two lines crossing at a shallow angle (:func:`_crossings`): two
#: lines of width w crossing at θ skeletonise into forks about w/tan(θ/2) apart, 10 radii
#: at 23°, so :data:`MERGE` alone splits a script l's loop or an e's eye
CROSSING_REACH = 16.0
#: a shallow crossing's arms leave along its bridge within this (degrees) on either side,
#: and each line through it bends by less than :data:`CROSSING_BEND`; an H's stems (90°)
#: or a k's arm (45°) beside its stem are two junctions, not a crossing
CROSSING_ARM = 35.0
CROSSING_BEND = 30.0
#: a junction-to-tip branch shorter than this × the junction's radius (+ 1 px) is a spur,
#: unless its tip's ink disc pokes out of the junction's by more than REACH_OUT × its
#: radius + 1 px (:func:`_reaches_out`)
SPUR = 1.6
REACH_OUT = 0.5
#: a short branch whose tip's ink radius is at most this (px) and lies on a band of the
#: paper's ruling is the line's burr beside a stroke (:func:`_drop_spurs`)
BURR = 1.0
#: branch ends at a junction that bend by less than this (degrees) continue each other
STRAIGHT = 50.0
#: ends left over at a junction are joined while they bend by less than this (degrees): an
#: R's leg leaves its bowl at 135°; a hairpin sharper than this is two strokes (a fit
#: rounds such a reversal off unless it spends time and targets on it)
TURN = 140.0
#: how much further left counts as much as higher up when choosing where a stroke begins:
#: a stroke starts at its top end (strokes are pulled down) unless it rises by less than
#: this share of its width (then at its left end)
ACROSS_WEIGHT = 0.4
#: an open stroke whose ends lie within this share of its length of each other, and which
#: is round (its isoperimetric quotient 4πA/P², the gap closing it, at least
#: :data:`ROUND`), is a loop drawn with a gap or an overshoot (:func:`_loop_with_gap`);
#: a V or a Λ this narrow is no rounder than 0.39
GAP_SHARE = 0.15
ROUND = 0.4
#: a loop with a gap whose ends lie in the bottom this share of its height is run
#: clockwise, set off leftwards from the bottom; any other counter-clockwise
LOW_GAP = 0.25
#: a loop a stroke runs clockwise is turned counter-clockwise, where the stroke goes on
#: past it, only if it then runs through the loop's junction at most this many degrees
#: less straight than before (:func:`_loops_turned`)
LOOP_SLACK = 30.0
#: a loop whose middle lies this share of its height or more below its junction hangs
#: from it (a g's, an f's tail): it is left the way the stroke runs into it
HANGS = 0.25
#: arms meeting at an inner angle below this (degrees) make a cusp, drawn out and back
CUSP = 60.0
#: the point of a cusp reaches at most this many ink radii past the fork
CUSP_REACH = 14.0
#: window (samples) of the moving average that smooths the skeleton's staircase
SMOOTH = 5
#: a tip is carried on along the direction of its last this many ink radii (at least
#: 3 px) of skeleton, at most :data:`TIP_REACH` radii + 2 px further (:func:`_extend_tips`)
TIP_BACK = 2.0
TIP_REACH = 3.0
#: share of a stroke's height trimmed off its top and its bottom to make the core by which
#: strokes fall into lines (:func:`_ordered`): the middle half of each
CORE_TRIM = 0.25
#: strokes of one line whose horizontal extents overlap by more than this share of the
#: wider one's are a column, drawn top to bottom (:func:`_ordered`)
COLUMN = 0.5
#: a line of strokes each no larger than this share of the next line's height is its
#: marks (accents, a kana's voicing marks) when it lies within :data:`MARK_REACH` of that
#: line's height above it, over its end (its middle right of :data:`MARK_END` of the
#: line's width, and at most :data:`MARK_PAST` of its height past its right edge):
#: drawn in that line, not before it (:func:`_marks_joined`). Over KanjiVG's voiced kana
#: the marks measure 0.10–0.21 of the line's height, 0.16 of it above the line at most
#: and 0.12 past its right edge.
MARK = 0.4
MARK_REACH = 0.5
MARK_END = 2 / 3
MARK_PAST = 0.25
#: ... and so is a line of dots (ink at least half as tall as wide, and the other way)
#: each over a stroke of the line below no wider than this many times the dot, within
#: :data:`MARK_REACH` of that line's height above it: an i's or a j's dot, drawn after
#: its stem; a dot over a wider stroke (文's) keeps its place, and so does a dash (う's)
STEM = 1.5


@dataclass
class StrokeGraph:
    """What the extraction found, for the report: ``strokes`` (k, 3) each (x, y, radius),
    in drawing order; counts of junctions, tips, spurs dropped, loops and dots."""

    strokes: list[np.ndarray]
    junctions: int
    tips: int
    spurs: int
    loops: int
    dots: int


class _Union:
    """Union-find over node ids (junction pixels that are one junction)."""

    def __init__(self) -> None:
        self.parent: dict[int, int] = {}

    def find(self, a: int) -> int:
        self.parent.setdefault(a, a)
        while self.parent[a] != a:
            self.parent[a] = self.parent[self.parent[a]]
            a = self.parent[a]
        return a

    def join(self, a: int, b: int) -> None:
        self.parent[self.find(a)] = self.find(b)


def radius_map(mask: np.ndarray) -> np.ndarray:
    """Ink radius at each ink pixel (px): the exact Euclidean distance to the nearest
    paper pixel's centre less ½ (a stroke n pixels wide has radius n/2 at its axis)."""
    import cv2

    dist = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return np.maximum(dist - 0.5, 0.5).astype(np.float64)


def stroke_graph(mask: np.ndarray, ruling: np.ndarray | None = None) -> StrokeGraph:
    """The strokes of the ink ``mask`` (H, W) bool (module docstring); ``ruling`` (H, W)
    bool: the bands of the paper's ruled lines taken out of it, where a short, thin
    branch is a burr of the line beside a stroke, however far it pokes out
    (:func:`_drop_spurs`)."""
    radius = radius_map(mask)
    skeleton = thinned(mask, radius)
    branches, nodes = _branches(skeleton, radius)
    spurs = _drop_spurs(branches, nodes, ruling)
    _crossings(branches, nodes)
    _extend_tips(branches, nodes, mask, radius)
    _cusps(branches, nodes)
    chains, loops = _chain(branches, nodes)
    chains = [_loops_turned(chain, branches, nodes) for chain in chains]
    strokes = [_stroke_points(chain, branches, nodes, radius) for chain in chains]
    strokes = [s for s in strokes if len(s) >= 2]
    strokes, dots = _dots(mask, radius, strokes)
    strokes = _directed(strokes) + dots
    junctions = sum(1 for n in nodes.values() if n.degree >= 3)
    tips = sum(1 for n in nodes.values() if n.degree == 1)
    return StrokeGraph(_ordered(strokes), junctions, tips, spurs, loops, len(dots))


#: a piece of ink whose skeleton spans less than this share of the piece's extent (less
#: its widest ink's diameter) was partly erased by the thinning (:func:`thinned`)
ERASED = 0.8


def thinned(mask: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """The skeleton (H, W) bool of the ink ``mask``: scikit-image's default thinning
    (Zhang's), except for a piece of ink (8-connected) whose skeleton spans, along the
    piece's longer side, less than :data:`ERASED` of the piece's extent less its widest
    ink's diameter (``radius``: :func:`radius_map`): a thin line at 45°, one of whose
    staircase rows Zhang's two sub-iterations strip from both sides at once, loses half
    or all of its skeleton. Such a piece is thinned again by Lee's method."""
    import cv2
    from skimage.morphology import skeletonize

    skeleton = skeletonize(mask)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8))
    if count < 2:
        return skeleton
    widest = np.zeros(count)
    np.maximum.at(widest, labels[mask], radius[mask])
    rows, cols = np.nonzero(skeleton)
    of = labels[rows, cols]
    low = np.full((count, 2), np.inf)
    high = np.full((count, 2), -np.inf)
    np.minimum.at(low, of, np.column_stack((cols, rows)))
    np.maximum.at(high, of, np.column_stack((cols, rows)))
    spans = np.where(np.isfinite(low), high - low + 1, 0.0)  # (count, 2): x, y
    extent = stats[:, [cv2.CC_STAT_WIDTH, cv2.CC_STAT_HEIGHT]].astype(float)
    longer = np.argmax(extent, axis=1)
    span = spans[np.arange(count), longer]
    erased = span < ERASED * (extent[np.arange(count), longer] - 2 * (widest + 0.5))
    erased[0] = False  # the paper
    for label in np.flatnonzero(erased):
        x, y, w, h = (int(v) for v in stats[label, :4])
        piece = labels[y:y + h, x:x + w] == label
        window = skeleton[y:y + h, x:x + w]
        window[piece] = skeletonize(piece, method="lee")[piece]
    return skeleton


def skeleton_paths(skeleton: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """The skeleton's pixels (N, 2) as (row, col), each one's degree (N,), and its paths:
    pixel index arrays from a tip or junction pixel through pixels of degree 2 to the next
    tip or junction, then each isolated cycle from its first pixel back to it.

    The graph of 8-neighbours is scikit-image's :func:`~skimage.graph.pixel_graph`, with the
    edges among a cluster of junction pixels cut to their minimum spanning tree; paths are
    walked in pixel order. That is :class:`skan.Skeleton`'s graph and its paths, in its
    order (tests/test_tracing.py compares them), without skan's path builder, a numba
    function compiled anew in every process (3–4 s before a process's first trace) and
    skan's imports (pandas, networkx: 1.3 s)."""
    from scipy.sparse import coo_matrix, csgraph
    from skimage.graph import pixel_graph

    graph, pixels = pixel_graph(skeleton, mask=skeleton.astype(bool), connectivity=2)
    degrees = np.diff(graph.indptr)
    junction = degrees >= 3
    among = graph.tocoo()
    keep = junction[among.row] & junction[among.col]
    if keep.any():  # a cluster of junction pixels: its edges cut to a spanning tree
        cluster = coo_matrix((among.data[keep], (among.row[keep], among.col[keep])),
                             shape=graph.shape).tocsr()
        cluster.sort_indices()
        tree = csgraph.minimum_spanning_tree(cluster)
        graph = (graph - (cluster - (tree + tree.T))).tocsr()
        graph.eliminate_zeros()
        degrees = np.diff(graph.indptr)
    neighbours = np.split(graph.indices, graph.indptr[1:-1])
    visited: set[tuple[int, int]] = set()

    def walk(node: int, step: int) -> np.ndarray:
        path, start = [node], node
        while (node, step) not in visited:
            visited.add((node, step))
            visited.add((step, node))
            path.append(step)
            if degrees[step] != 2 or step == start:
                break
            first, second = neighbours[step]
            node, step = step, int(second if first == node else first)
        return np.asarray(path)

    paths = [walk(node, int(n)) for node in np.flatnonzero(degrees != 2).tolist()
             for n in neighbours[node] if (node, int(n)) not in visited]
    paths += [walk(node, int(neighbours[node][0])) for node in range(len(degrees))
              if degrees[node] > 0 and (node, int(neighbours[node][0])) not in visited]
    rows, cols = np.unravel_index(pixels, skeleton.shape)
    return np.column_stack((rows, cols)), degrees, paths


@dataclass
class _Branch:
    """A skeleton path: points (k, 2) as (x, y), its end nodes, and whether it is kept."""

    points: np.ndarray
    ends: tuple[int, int]
    kept: bool = True

    @property
    def length(self) -> float:
        return _length(self.points)


def _length(points: np.ndarray) -> float:
    """Length (px) of the polyline ``points`` (k, 2)."""
    return float(np.hypot(*np.diff(points, axis=0).T).sum()) if len(points) > 1 else 0.0


@dataclass
class _Node:
    """A junction (merged pixels), a tip, or a pass-through: centre (x, y), radius, and
    the branch ends (branch index, 0 or 1 for its first or last point) that meet here."""

    centre: np.ndarray
    radius: float
    ends: list[tuple[int, int]]

    @property
    def degree(self) -> int:
        return len(self.ends)


def _branches(skeleton: np.ndarray, radius: np.ndarray
              ) -> tuple[list[_Branch], dict[int, _Node]]:
    """The skeleton's paths (:func:`skeleton_paths`) and their end nodes, junction pixels
    merged (step 2)."""
    if skeleton.sum() < 2:
        return [], {}
    coordinates, degrees, paths = skeleton_paths(skeleton)
    raw = []
    for ids in paths:
        rc = coordinates[ids]
        raw.append((rc[:, ::-1].astype(np.float64) + 0.5, int(ids[0]), int(ids[-1])))
    union = _Union()
    absorbed = set()
    for i, (pts, a, b) in enumerate(raw):
        if degrees[a] >= 3 and degrees[b] >= 3 and a != b:
            ra = radius[int(pts[0, 1]), int(pts[0, 0])]
            rb = radius[int(pts[-1, 1]), int(pts[-1, 0])]
            if _length(pts) <= MERGE * max(ra, rb) + 1.5:
                union.join(a, b)
                absorbed.add(i)
    members: dict[int, list[np.ndarray]] = {}
    for pts, a, b in raw:
        for node, p in ((a, pts[0]), (b, pts[-1])):
            members.setdefault(union.find(node), []).append(p)
    nodes: dict[int, _Node] = {}
    for key, pts in members.items():
        centre = np.mean(pts, axis=0)
        r = max(radius[int(p[1]), int(p[0])] for p in pts)
        nodes[key] = _Node(centre, float(r), [])
    branches = []
    for i, (pts, a, b) in enumerate(raw):
        if i in absorbed:
            continue
        ends = (union.find(a), union.find(b))
        branches.append(_Branch(pts, ends))
        k = len(branches) - 1
        nodes[ends[0]].ends.append((k, 0))
        nodes[ends[1]].ends.append((k, 1))
    return branches, {k: n for k, n in nodes.items() if n.ends}


def _drop_spurs(branches: list[_Branch], nodes: dict[int, _Node],
                ruling: np.ndarray | None = None) -> int:
    """Drop junction-to-tip branches shorter than the junction's ink (step 2); how many
    were dropped. A short branch ending in a pixel or two of ink on a band of the paper's
    ruling (``ruling``, or within a pixel of one) is dropped even where its ink reaches
    out of the junction's: it is the line's burr beside a stroke, left where the
    stroke's blur darkened the line, not a stroke's end (:func:`_burr`)."""
    near_line = None
    if ruling is not None:
        import cv2

        near_line = cv2.dilate(ruling.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    dropped = 0
    for _ in range(3):  # a spur's removal may leave another behind it
        again = False
        for k, br in enumerate(branches):
            if not br.kept:
                continue
            a, b = (nodes[e] for e in br.ends)
            for tip, fork in ((a, b), (b, a)):
                end = br.points[0] if tip is a else br.points[-1]
                if tip.degree == 1 and fork.degree >= 3 and \
                        br.length < SPUR * fork.radius + 1.0 and \
                        (not _reaches_out(end, tip, fork) or _burr(end, tip, near_line)) and \
                        not _narrow_fork(branches, fork, (k, 1 if tip is a else 0)):
                    br.kept = False
                    tip.ends.remove((k, 0 if tip is a else 1))
                    fork.ends.remove((k, 1 if tip is a else 0))
                    dropped += 1
                    again = True
                    break
        if not again:
            break
    return dropped


def _burr(end: np.ndarray, tip: _Node, near_line: np.ndarray | None) -> bool:
    """Whether a branch's tip at ``end`` (x, y) is a ruled line's burr: a pixel or two of
    ink (:data:`BURR` radius at most; a stroke's end is as wide as the stroke) lying on
    ``near_line`` (H, W) bool, the ruling's bands grown by a pixel (False for None)."""
    if near_line is None or tip.radius > BURR:
        return False
    h, w = near_line.shape
    col, row = (int(np.clip(v, 0, n - 1)) for v, n in ((end[0], w), (end[1], h)))
    return bool(near_line[row, col])


def _reaches_out(end: np.ndarray, tip: _Node, fork: _Node) -> bool:
    """Whether a short branch's ink reaches out of its junction's: the tip's inscribed
    disc (its ink radius, about the stroke's own at a stroke's end, a pixel or two at an
    outline's bump) pokes out of the junction's by more than :data:`REACH_OUT` of its
    radius + 1 px. A stroke ending just past a junction where several thick strokes merge
    (whose radius, the widest of the merged pixels', is then two or three strokes' radii)
    is such a branch; a spur of the outline lies within the junction's ink."""
    reach = float(np.hypot(*(end - fork.centre))) + tip.radius
    return reach > fork.radius + REACH_OUT * tip.radius + 1.0


def _crossings(branches: list[_Branch], nodes: dict[int, _Node]) -> None:
    """Two forks joined by a short bridge are one crossing of two lines at a shallow angle
    (step 2) when each fork's two other arms leave along the bridge, within
    :data:`CROSSING_ARM` of it on either side, and pair across it into two lines that
    bend by less than :data:`CROSSING_BEND`: the bridge is dropped and the forks become
    one junction of four ends at its middle, its radius reaching both forks, so the two
    lines go straight through it as at a wide crossing."""
    for k, bridge in enumerate(branches):
        a_key, b_key = bridge.ends
        if not bridge.kept or a_key == b_key:
            continue
        a, b = nodes[a_key], nodes[b_key]
        if a.degree != 3 or b.degree != 3 or bridge.length > CROSSING_REACH * max(
                a.radius, b.radius) + 1.5:
            continue
        axis = b.centre - a.centre
        span = float(np.hypot(*axis))
        if span == 0.0:
            continue
        axis = axis / span
        a_arms = _arms_along(branches, a, (k, 0), -axis)
        b_arms = _arms_along(branches, b, (k, 1), axis) if a_arms else None
        if b_arms is None:
            continue
        (a1, u1), (a2, u2) = a_arms
        (b1, v1), (b2, v2) = b_arms
        bend = min(max(_bend(u1, v1), _bend(u2, v2)), max(_bend(u1, v2), _bend(u2, v1)))
        if bend >= CROSSING_BEND:
            continue
        bridge.kept = False
        a.centre = (a.centre + b.centre) / 2.0
        a.radius = max(a.radius, b.radius, span / 2.0)
        a.ends = [a1, a2, b1, b2]
        for i, j in (b1, b2):
            ends = list(branches[i].ends)
            ends[j] = a_key
            branches[i].ends = (ends[0], ends[1])
        b.ends = []


def _arms_along(branches: list[_Branch], node: _Node, bridge_end: tuple[int, int],
                along: np.ndarray) -> list[tuple[tuple[int, int], np.ndarray]] | None:
    """A fork's two ends other than ``bridge_end``, each with the direction it leaves in,
    when both leave within :data:`CROSSING_ARM` of ``along``; None otherwise."""
    ends = [e for e in node.ends if e != bridge_end]
    dirs = [_outward(branches[i], j, node) for i, j in ends]
    if len(ends) != 2 or any(_bend(-along, u) > CROSSING_ARM for u in dirs):
        return None
    return list(zip(ends, dirs, strict=True))


def _extend_tips(branches: list[_Branch], nodes: dict[int, _Node], mask: np.ndarray,
                 radius: np.ndarray) -> None:
    """Carry each tip on to where its stroke ends: thinning stops short of a stroke's end,
    by up to a radius at a round or pointed end, and by several where a narrow V's arms
    merge in the ink before its point. From the tip, along the direction of the branch's
    last :data:`TIP_BACK` radii, the ink ends at a distance e (found in ½-px steps, at
    most :data:`TIP_REACH` radii + 2 px); the stroke's centre line ends one radius r
    before that, so the tip moves on by e − r when that is ½ px or more: a round cap's
    centre, a pointed end's point. r is the ink's radius at the tip, or, at the point of
    a cusp (a tip branch from a narrow fork, :func:`_narrow_fork`), the median radius
    along the two arms (the merged arms' ink is about twice as wide as either); a tail
    too short for a direction of its own is carried on along the one from its fork."""
    height, width = mask.shape
    for k, br in enumerate(branches):
        if not br.kept:
            continue
        for end in (0, 1):
            if nodes[br.ends[end]].degree != 1:
                continue
            pts = br.points[::-1] if end == 0 else br.points  # (n, 2), ending at the tip
            tip = pts[-1]
            r = _tip_radius(branches, nodes, radius, k, end)
            back = np.hypot(*(pts - tip).T)
            far = np.flatnonzero(back >= max(3.0, TIP_BACK * r))
            # a tail shorter than that (a cusp's point past its fork): from the fork
            u = tip - (pts[far[-1]] if far.size else nodes[br.ends[1 - end]].centre)
            if np.hypot(*u) == 0:
                continue
            u = u / np.hypot(*u)
            steps = tip + np.arange(1, int(2 * (TIP_REACH * r + 2.0)) + 1)[:, None] * 0.5 * u
            cols, rows = np.floor(steps.T).astype(int)
            inside = (cols >= 0) & (cols < width) & (rows >= 0) & (rows < height)
            ink = np.zeros(len(steps), bool)
            ink[inside] = mask[rows[inside], cols[inside]]
            run = int(np.argmin(ink)) if not ink.all() else len(ink)  # ink steps in a row
            move = 0.5 * run + 0.25 - r  # the ink ends between the last ink step and the next
            if move < 0.5:
                continue
            new = tip + move * u
            br.points = (np.vstack((new, br.points)) if end == 0
                         else np.vstack((br.points, new)))


def _tip_radius(branches: list[_Branch], nodes: dict[int, _Node], radius: np.ndarray,
                k: int, end: int) -> float:
    """The ink radius of the stroke that ends at branch ``k``'s tip ``end``
    (:func:`_extend_tips`)."""
    tip = branches[k].points[0 if end == 0 else -1]
    at_tip = float(radius[int(tip[1]), int(tip[0])])
    fork = nodes[branches[k].ends[1 - end]]
    if fork.degree != 3 or not _narrow_fork(branches, fork, (k, 1 - end)):
        return at_tip
    arms = []
    for i in {i for i, _ in fork.ends} - {k}:
        pts = branches[i].points
        arms.extend(radius[pts[:, 1].astype(int), pts[:, 0].astype(int)])
    return min(at_tip, float(np.median(arms))) if arms else at_tip


def _cusps(branches: list[_Branch], nodes: dict[int, _Node]) -> None:
    """A tip branch at a fork whose two other arms meet at an inner angle under
    :data:`CUSP` (and no longer than :data:`CUSP_REACH` radii) is the point of a cusp: a
    hand goes out to it and back. It becomes an out-and-back branch with both ends at the
    fork, so the two arms chain through it."""
    for k, br in enumerate(branches):
        if not br.kept:
            continue
        a, b = (nodes[e] for e in br.ends)
        for tip, fork, fork_end in ((a, b, 1), (b, a, 0)):
            if not (tip.degree == 1 and fork.degree == 3):
                continue
            if br.length > CUSP_REACH * fork.radius + 2.0 or \
                    not _narrow_fork(branches, fork, (k, fork_end)):
                continue
            out = br.points if fork_end == 0 else br.points[::-1]
            br.points = np.vstack((out, out[-2::-1]))
            key = br.ends[fork_end]
            br.ends = (key, key)
            tip.ends.clear()
            fork.ends.remove((k, fork_end))
            fork.ends.extend([(k, 0), (k, 1)])
            break


def _narrow_fork(branches: list[_Branch], fork: _Node, tail: tuple[int, int]) -> bool:
    """Whether the two arms of a three-way ``fork`` other than the branch end ``tail``
    meet at an inner angle under :data:`CUSP`: the tail is then the point of a cusp (a
    narrow V whose arms merge in the ink near its point), however short, not a spur of
    the outline."""
    others = [e for e in fork.ends if e != tail]
    if len(others) != 2:
        return False
    u, v = (_outward(branches[i], j, fork) for i, j in others)
    return 180.0 - _bend(u, v) < CUSP


def _outward(br: _Branch, end: int, node: _Node) -> np.ndarray:
    """Unit direction in which branch ``br`` leaves ``node`` at its end ``end``: from
    its point at the junction's radius to the one a few radii further (skipping the
    skeleton's wobble inside the junction)."""
    pts = br.points if end == 0 else br.points[::-1]
    d = np.hypot(*(pts - node.centre).T)
    near = int(np.argmax(d >= node.radius)) if np.any(d >= node.radius) else 0
    reach = node.radius + max(4.0, 2.0 * node.radius)
    far_idx = np.flatnonzero(d >= reach)
    # a branch that never gets that far: its farthest point (a cusp's tip, not its
    # last point, which is back at the junction)
    far = int(far_idx[0]) if far_idx.size else int(np.argmax(d))
    if far <= near:
        near, far = 0, len(pts) - 1
    v = pts[far] - pts[near]
    n = float(np.hypot(*v))
    return v / n if n > 0 else np.zeros(2)


def _bend(u: np.ndarray, v: np.ndarray) -> float:
    """Degrees by which a path entering along −u and leaving along v turns (0: straight)."""
    c = float(np.clip(-(u @ v), -1.0, 1.0))
    return math.degrees(math.acos(c))


def _pairs(nodes: dict[int, _Node], branches: list[_Branch]
           ) -> dict[tuple[int, int], tuple[int, int]]:
    """Branch end -> the branch end it continues into, at every node (step 3)."""
    pair: dict[tuple[int, int], tuple[int, int]] = {}
    for node in nodes.values():
        ends = list(node.ends)
        if len(ends) == 2:
            pair[ends[0]], pair[ends[1]] = ends[1], ends[0]
            continue
        if len(ends) < 2:
            continue
        dirs = {e: _outward(branches[e[0]], e[1], node) for e in ends}
        options = sorted((_bend(dirs[a], dirs[b]), i, j)
                         for i, a in enumerate(ends) for j, b in enumerate(ends) if i < j)
        free = set(ends)
        for limit in (STRAIGHT, TURN):
            for bend, i, j in options:
                a, b = ends[i], ends[j]
                if bend < limit and a in free and b in free:
                    pair[a], pair[b] = b, a
                    free -= {a, b}
    return pair


def _chain(branches: list[_Branch], nodes: dict[int, _Node]
           ) -> tuple[list[list[tuple[int, int]]], int]:
    """Strokes as lists of (branch, direction 0 = as stored, 1 = reversed); loop count."""
    pair = _pairs(nodes, branches)
    seen: set[int] = set()
    chains: list[list[tuple[int, int]]] = []

    def walk(k: int, enter: int) -> list[tuple[int, int]]:
        out = []
        while k not in seen:
            seen.add(k)
            out.append((k, enter))
            nxt = pair.get((k, 1 - enter))
            if nxt is None:
                break
            k, enter = nxt
        return out

    starts = [(k, e) for k, br in enumerate(branches) if br.kept for e in (0, 1)
              if (k, e) not in pair]
    for k, e in starts:
        if k not in seen:
            chains.append(walk(k, e))
    loops = 0
    for k, br in enumerate(branches):
        if br.kept and k not in seen:
            chains.append(walk(k, 0))
            loops += 1
    return chains, loops


def _reversed(chain: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The same chain walked from its other end."""
    return [(k, 1 - enter) for k, enter in chain[::-1]]


def _begins_at_last(first: np.ndarray, last: np.ndarray) -> bool:
    """Whether a writer begins an open stroke with ends ``first`` and ``last`` (x, y) at
    ``last``: its top end, or its left one where it is nearly level (step 4)."""
    return bool(ACROSS_WEIGHT * last[0] + last[1] < ACROSS_WEIGHT * first[0] + first[1])


def _loops_turned(chain: list[tuple[int, int]], branches: list[_Branch],
                  nodes: dict[int, _Node]) -> list[tuple[int, int]]:
    """An open chain with each loop it runs (branches that leave a junction and come back
    to it) turned counter-clockwise on the page, as the Latin script's ovals and loops
    are drawn (an o, an e's eye, an l's loop on a word's line), unless

    - the loop hangs from its junction (:data:`HANGS`: a g's or an f's tail, drawn on
      down the stem and round, clockwise or not), or
    - the chain goes on past the loop and runs straighter through the junction the way
      it is (:data:`LOOP_SLACK`: a stem that goes on up into a bowl and comes out into a
      leg, an R's, is drawn clockwise).

    Such a loop can be run either way between the chain's two passes through its
    junction, so the chain's ends and the rest of its path stay as they are. Loops are
    taken from the chain's start, each the shortest that comes back to where it left."""
    if _closes(chain, branches):
        return chain
    if _loop_with_gap(np.vstack([branches[k].points if enter == 0 else
                                 branches[k].points[::-1] for k, enter in chain])):
        return chain  # its way round is chosen whole (:func:`_directed`)
    (k0, e0), (k1, e1) = chain[0], chain[-1]
    # the direction the stroke will be drawn in (:func:`_directed` turns it, later, on its
    # points: the chain keeps its order, so a chain without a loop to turn traces as ever)
    backwards = _begins_at_last(branches[k0].points[0 if e0 == 0 else -1],
                                branches[k1].points[-1 if e1 == 0 else 0])
    out = list(chain)
    i = 0
    while i < len(out):
        start = branches[out[i][0]].ends[out[i][1]]
        j = next((j for j in range(i, len(out))
                  if branches[out[j][0]].ends[1 - out[j][1]] == start), None)
        if j is None:
            i += 1
            continue
        loop = out[i:j + 1]
        pts = np.vstack([branches[k].points if enter == 0 else branches[k].points[::-1]
                         for k, enter in loop])
        clockwise = _clockwise(pts) != backwards
        y = pts[:, 1]
        hangs = float(y.mean()) - nodes[start].centre[1] > HANGS * float(np.ptp(y))
        if len(pts) > 3 and clockwise and not hangs:
            turned = out[:i] + _reversed(loop) + out[j + 1:]
            goes_on = 0 < i and j < len(out) - 1
            if not goes_on or _straightest_join(turned, i, j, branches, nodes) < \
                    _straightest_join(out, i, j, branches, nodes) + LOOP_SLACK:
                out = turned
        i = j + 1
    return out


def _straightest_join(chain: list[tuple[int, int]], i: int, j: int,
                      branches: list[_Branch], nodes: dict[int, _Node]) -> float:
    """The least bend (degrees) of the chain's joins into its branch i and out of its
    branch j, the joins it has of the two (180 for none)."""
    least = 180.0
    for a, b in ((i - 1, i), (j, j + 1)):
        if a < 0 or b >= len(chain):
            continue
        (ka, ea), (kb, eb) = chain[a], chain[b]
        node = nodes[branches[kb].ends[eb]]
        least = min(least, _bend(_outward(branches[ka], 1 - ea, node),
                                 _outward(branches[kb], eb, node)))
    return least


def _stroke_points(chain: list[tuple[int, int]], branches: list[_Branch],
                   nodes: dict[int, _Node], radius: np.ndarray) -> np.ndarray:
    """A chain's points (k, 3): x, y, radius; the junctions it passes through bridged
    (module docstring, step 3), the staircase smoothed."""
    parts = []
    for i, (k, enter) in enumerate(chain):
        br = branches[k]
        pts = br.points if enter == 0 else br.points[::-1]
        start_node, end_node = (nodes[n] for n in (br.ends if enter == 0 else br.ends[::-1]))
        keep = np.ones(len(pts), bool)
        if i > 0:  # entered through a junction: cut its wobble
            keep &= np.hypot(*(pts - start_node.centre).T) >= start_node.radius
        if i < len(chain) - 1:
            keep &= np.hypot(*(pts - end_node.centre).T) >= end_node.radius
        if not keep.any():  # (one point kept is a cusp's point past its fork)
            keep[[0, -1]] = True
        parts.append(pts[keep])
    pts = np.vstack(parts)
    closed = len(chain) > 0 and _closes(chain, branches)
    pts = _smooth(pts, closed)
    rows = np.clip(pts[:, 1].astype(int), 0, radius.shape[0] - 1)
    cols = np.clip(pts[:, 0].astype(int), 0, radius.shape[1] - 1)
    r = _smooth(radius[rows, cols][:, None], closed)[:, 0]
    return _simplify(np.column_stack((pts, r)), closed)


def _closes(chain: list[tuple[int, int]], branches: list[_Branch]) -> bool:
    k0, e0 = chain[0]
    k1, e1 = chain[-1]
    first = branches[k0].ends[e0]
    last = branches[k1].ends[1 - e1]
    return first == last


def _smooth(pts: np.ndarray, closed: bool) -> np.ndarray:
    """Moving average over :data:`SMOOTH` samples; an open stroke keeps its two ends and
    its cusps' points."""
    n = len(pts)
    if n < 3:
        return pts
    w = min(SMOOTH, n if closed else (n - 1) | 1)
    if w < 3:
        return pts
    h = w // 2
    if closed and np.allclose(pts[0], pts[-1]):
        body = pts[:-1]
        ext = np.vstack((body[-h:], body, body[:h]))
        out = np.stack([np.convolve(ext[:, c], np.ones(w) / w, mode="valid")
                        for c in range(pts.shape[1])], axis=1)
        return np.vstack((out, out[:1]))
    ext = np.vstack((np.repeat(pts[:1], h, 0), pts, np.repeat(pts[-1:], h, 0)))
    out = np.stack([np.convolve(ext[:, c], np.ones(w) / w, mode="valid")
                    for c in range(pts.shape[1])], axis=1)
    out[0], out[-1] = pts[0], pts[-1]
    if pts.shape[1] < 2:  # a radius profile
        return out
    # a cusp's point (an inner angle under CUSP: the two samples ``h`` away on either
    # side closer to each other than to it) keeps its place: averaged with the samples
    # on both legs it would move back along them
    xy = pts[:, :2]
    before, after = xy[: n - 2 * h], xy[2 * h:]
    mid = xy[h: n - h]
    gap = np.hypot(*(before - after).T)
    legs = np.minimum(np.hypot(*(mid - before).T), np.hypot(*(mid - after).T))
    turn = np.flatnonzero((gap < 2.0 * math.sin(math.radians(CUSP) / 2) * legs)
                          & (legs > 0)) + h
    out[turn] = pts[turn]
    return out


def _simplify(pts: np.ndarray, closed: bool, tol: float = 0.2) -> np.ndarray:
    """Drop points within ``tol`` px of the line through their neighbours (Douglas–Peucker,
    :meth:`shapely.LineString.simplify`), radii kept with their points."""
    from shapely import LineString

    if len(pts) < 3:
        return pts
    line = LineString(pts[:, :2]).simplify(tol, preserve_topology=False)
    kept = np.asarray(line.coords)
    # map the kept coordinates back to their rows: simplify returns a subset, in order,
    # of the very same numbers (compared as Python floats: a numpy call per point cost
    # more than the rest of the tracing together)
    rows = pts[:, :2].tolist()
    idx = []
    j = 0
    for x, y in kept.tolist():
        while j < len(rows) and (abs(rows[j][0] - x) > 1e-9 or abs(rows[j][1] - y) > 1e-9):
            j += 1
        idx.append(min(j, len(rows) - 1))
    return pts[np.unique(idx)]


def _widest(radius: np.ndarray, labels: np.ndarray, stats: np.ndarray, label: int) -> float:
    """The inscribed radius of blob ``label`` (its largest ink radius), read in its box."""
    import cv2

    x0, y0, w, h = (int(stats[label, c]) for c in (cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP,
                                                  cv2.CC_STAT_WIDTH, cv2.CC_STAT_HEIGHT))
    box = labels[y0:y0 + h, x0:x0 + w] == label
    return float(radius[y0:y0 + h, x0:x0 + w][box].max())


def _pen_radius(strokes: list[np.ndarray]) -> float:
    """The radius most of the drawing's ink length is drawn with: the median of the
    strokes' radii weighted by length (a straight stroke keeps two points after
    :func:`_simplify`, so a median over points would be the specks')."""
    if not strokes:
        return 0.0
    radius = np.concatenate([(s[1:, 2] + s[:-1, 2]) / 2 if len(s) > 1 else s[:, 2]
                             for s in strokes])
    length = np.concatenate([np.hypot(*np.diff(s[:, :2], axis=0).T) if len(s) > 1
                             else np.ones(1) for s in strokes])
    order = np.argsort(radius)
    cumulative = np.cumsum(length[order])
    return float(radius[order][np.searchsorted(cumulative, 0.5 * cumulative[-1])])


def _dots(mask: np.ndarray, radius: np.ndarray, strokes: list[np.ndarray]
          ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The strokes without specks, and dabs for the blobs that no stroke passes through,
    or only a stroke no longer than the blob is wide (step 5). A blob smaller than a dab
    of the drawing's own pen (π r² for the pen's radius r, :func:`_pen_radius`, at least
    3 px²) is a speck of noise: dropped, with any stroke inside it."""
    import cv2

    count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask.astype(np.uint8))
    pen = _pen_radius(strokes)
    least = max(3.0, math.pi * pen * pen)
    speck = stats[:, cv2.CC_STAT_AREA] < least
    covered = np.zeros(count, bool)
    kept = []
    blobs_of = []
    for s in strokes:
        rows = np.clip(s[:, 1].astype(int), 0, mask.shape[0] - 1)
        cols = np.clip(s[:, 0].astype(int), 0, mask.shape[1] - 1)
        blobs_of.append(np.unique(labels[rows, cols]))
    alone = np.bincount(np.concatenate(blobs_of), minlength=count) == 1 if blobs_of else []
    for s, blobs in zip(strokes, blobs_of, strict=True):
        b = blobs[0]
        if len(blobs) == 1 and b and alone[b] and _length(s[:, :2]) < 2.0 * _widest(
                radius, labels, stats, b):
            continue  # no longer than the blob is wide: a dot, left for a dab below
        covered[blobs] = True
        if not np.all(speck[blobs] | (blobs == 0)):
            kept.append(s)
    dots = []
    for label in np.flatnonzero(~covered[1:] & ~speck[1:]) + 1:
        r = _widest(radius, labels, stats, label)
        cx, cy = centroids[label]
        half = max(0.5, float(stats[label, cv2.CC_STAT_WIDTH]) / 2.0 - r)
        dots.append(np.array([[cx + 0.5 - half, cy + 0.5, r], [cx + 0.5 + half, cy + 0.5, r]]))
    return kept, dots


def _shoelace(pts: np.ndarray) -> float:
    """Twice the signed area of the polygon ``pts`` (k, 2+), closed from its last point to
    its first; positive where it runs clockwise on the page (y down)."""
    x, y = pts[:, 0], pts[:, 1]
    return float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _clockwise(pts: np.ndarray) -> bool:
    """Whether the closed polygon ``pts`` (k, 2+) runs clockwise on the page (y down: a
    positive shoelace sum)."""
    return _shoelace(pts) > 0


def _directed(strokes: list[np.ndarray]) -> list[np.ndarray]:
    """Each stroke begun where a writer begins it (module docstring, step 4)."""
    out = []
    for s in strokes:
        closed = len(s) > 3 and np.hypot(*(s[0, :2] - s[-1, :2])) < 1.0
        if closed:
            body = s[:-1]
            top = int(np.argmin(body[:, 1] + 1e-3 * body[:, 0]))
            body = np.roll(body, -top, axis=0)
            if _clockwise(body):  # turn it round
                body = np.vstack((body[:1], body[:0:-1]))
            s = np.vstack((body, body[:1]))
        elif _loop_with_gap(s):
            y = s[:, 1]
            low = 0.5 * (y[0] + y[-1]) > float(y.max()) - LOW_GAP * float(np.ptp(y))
            if _clockwise(s) != low:
                s = s[::-1].copy()
        elif _begins_at_last(s[0, :2], s[-1, :2]):
            s = s[::-1].copy()
        out.append(s)
    return out


def _loop_with_gap(pts: np.ndarray) -> bool:
    """Whether the open stroke ``pts`` (k, 2+) is a loop drawn with a gap or an overshoot
    between its ends: they lie within :data:`GAP_SHARE` of its length of each other, and it
    is round (:data:`ROUND`)."""
    xy = pts[:, :2]
    length = float(np.hypot(*np.diff(xy, axis=0).T).sum())
    gap = float(np.hypot(*(xy[0] - xy[-1])))
    if len(xy) < 4 or length <= 0 or gap > GAP_SHARE * length:
        return False
    area = 0.5 * abs(_shoelace(xy))
    return 4 * math.pi * area / (length + gap) ** 2 >= ROUND


def _marks_joined(lines: list[list[int]], boxes: list[tuple[float, float, float, float]],
                  inks: list[tuple[float, float, float, float]]
                  ) -> tuple[list[list[int]], set[int]]:
    """``lines`` (of stroke indices, top to bottom) with each line of marks joined to the
    line it sits on, so it is drawn in that line rather than before it, and the dots so
    joined over stems (each drawn after the column of its stem): a line whose every
    stroke is no larger (its box's longer side) than :data:`MARK` × the height of the line
    below it, whose bottom is at most :data:`MARK_REACH` × that height above that line's
    top, and which sits over the line's end (its middle right of :data:`MARK_END` of the
    line's width, and past its right edge by at most :data:`MARK_PAST` × its height: a
    kana's voicing marks, an accent on a word's last letter), or whose every stroke is a
    dot over a stem (:data:`STEM`: the i-dots of a line of print). A mark further out, a
    writer's dot or star beside a tag, is a line of its own, drawn first. A hand that
    has drawn a line then adds what sits over its end; a mark over the line's start or
    middle (え's first stroke) is drawn before it, top to bottom. Marks stacked in several
    lines join one by one, bottom up. ``inks``: each stroke's ink box (its box grown by
    its pen), what tells a dot from a dash."""
    def extent(line: list[int]) -> tuple[float, float, float, float, float]:
        left = min(boxes[i][0] for i in line)
        right = max(boxes[i][2] for i in line)
        top = min(boxes[i][1] for i in line)
        low = max(boxes[i][3] for i in line)
        return left, top, right, low, max(boxes[i][3] - boxes[i][1] for i in line)

    out = [list(line) for line in lines]
    dotted: set[int] = set()
    for k in range(len(out) - 2, -1, -1):
        left, _, right, low, _ = extent(out[k])
        below_left, below_top, below_right, _, height = extent(out[k + 1])
        small = all(max(boxes[i][2] - boxes[i][0], boxes[i][3] - boxes[i][1])
                    <= MARK * height for i in out[k])
        near = below_top - low <= MARK_REACH * height
        middle = 0.5 * (left + right)
        at_end = (below_left + MARK_END * (below_right - below_left) <= middle
                  <= below_right + MARK_PAST * height)
        dots = small and all(_dot_over_stem(i, out[k + 1], boxes, inks,
                                            MARK_REACH * height) for i in out[k])
        if small and near and at_end or dots:
            if dots and not (near and at_end):
                dotted.update(out[k])
            out[k + 1] = out[k] + out[k + 1]
            del out[k]
    return out, dotted


def _dot_over_stem(i: int, below: list[int], boxes: list[tuple[float, float, float, float]],
                   inks: list[tuple[float, float, float, float]], reach: float) -> bool:
    """Whether stroke ``i`` is a dot (its ink at least half as tall as wide, and the
    other way) over a stem among ``below``: a stroke no wider than :data:`STEM` × the
    dot's ink, under its middle, whose top is at most ``reach`` below the dot."""
    left, top, right, low = inks[i]
    size = max(right - left, low - top)
    if min(right - left, low - top) < 0.5 * size:
        return False  # a dash (う's first stroke), not a dot
    middle = 0.5 * (left + right)
    return any(boxes[j][0] - size <= middle <= boxes[j][2] + size
               and inks[j][2] - inks[j][0] <= STEM * size
               and 0.0 <= boxes[j][1] - boxes[i][3] <= reach for j in below)


def _ordered(strokes: list[np.ndarray]) -> list[np.ndarray]:
    """Strokes in lines top to bottom, each line left to right (module docstring, step 4):
    a line is a run of strokes whose vertical cores (their ink's extent, the centreline's
    grown by the stroke's pen, less :data:`CORE_TRIM` of its height at each end) overlap.
    A tag's letters are one line; lines of text are apart; and a long tail reaching down
    from a word does not pull the marks above it into its line, which are drawn first.
    Within a line, strokes one above the other over most of their width (:data:`COLUMN`:
    an a's stem and its bowl, a character's stacked parts) are a column, drawn top to
    bottom; columns go left to right by their left edge. A dot or a bar over a wider
    stroke is not its column, so a word's i-dots and t-bars still come after the stroke
    they sit on; the dots over stems a line takes in (:func:`_marks_joined`) join the
    column of the stroke under them, after its strokes."""
    boxes = [(s[:, 0].min(), s[:, 1].min(), s[:, 0].max(), s[:, 1].max()) for s in strokes]
    pens = [float(s[:, 2].max()) if s.shape[1] > 2 else 0.0 for s in strokes]
    inks = [(left - r, top - r, right + r, low + r)
            for (left, top, right, low), r in zip(boxes, pens, strict=True)]
    cores = [(top + CORE_TRIM * (low - top), low - CORE_TRIM * (low - top))
             for _, top, _, low in inks]
    lines: list[list[int]] = []
    bottom = -math.inf
    for i in sorted(range(len(strokes)), key=lambda i: cores[i][0]):
        if cores[i][0] > bottom:
            lines.append([])
        lines[-1].append(i)
        bottom = max(bottom, cores[i][1])
    lines, dotted = _marks_joined(lines, boxes, inks)
    order: list[int] = []
    for line in lines:
        columns: list[list[int]] = []  # each: members, left to right by first member
        spans: list[tuple[float, float]] = []
        for i in sorted((i for i in line if i not in dotted), key=lambda i: boxes[i][0]):
            left, right = boxes[i][0], boxes[i][2]
            for k, (a, b) in enumerate(spans):
                if min(right, b) - max(left, a) > COLUMN * max(right - left, b - a):
                    columns[k].append(i)
                    spans[k] = (min(a, left), max(b, right))
                    break
            else:
                columns.append([i])
                spans.append((left, right))
        for i in sorted((i for i in line if i in dotted), key=lambda i: boxes[i][0]):
            middle, size = 0.5 * (inks[i][0] + inks[i][2]), inks[i][2] - inks[i][0]
            under = [k for k, (a, b) in enumerate(spans) if a - size <= middle <= b + size]
            if under:  # the column it marks: the nearest under it
                columns[min(under, key=lambda k: abs(sum(spans[k]) / 2 - middle))].append(i)
            else:
                columns.append([i])
                spans.append((boxes[i][0], boxes[i][2]))
        columns.sort(key=lambda members: min(boxes[i][0] for i in members))
        for members in columns:  # top to bottom; marks after, left to right
            order += sorted(members, key=lambda i: (1, boxes[i][0], boxes[i][1]) if i in dotted
                            else (0, boxes[i][1], boxes[i][0]))
    return [strokes[i] for i in order]
