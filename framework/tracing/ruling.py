"""The ruled lines of notebook or graph paper, taken out of a picture's ink mask.

A sketch on ruled paper shows the paper's printed lines as ink wherever they are as dark
as the drawing's faintest strokes (a pencil over a notebook's blue lines): traced, each
would become a stroke across the page; and lines lighter than the ink still darken the
strokes they cross into burrs the skeleton grows spurs from. So the lines are looked for
in the *faint* ink (darker than :data:`FAINT` of the mask's threshold), whether or not
the mask holds them.

A *ruling* is told from a drawing by what no drawing is: at least :data:`LEAST_LINES`
straight lines, parallel, each printed across the picture (ink along at least
:data:`SEEN` of it, from edge to edge: :data:`SPAN`; as thick all along: :data:`UNIFORM`),
evenly spaced (each gap a whole number of spacings: a line may be missed), and a line at
most (:data:`FILLED`) of the places its spacing gives between the first and the last (a
word's upright stems may stand evenly apart, but not at every place of a spacing). Lines
within :data:`TILT` of the picture's rows are found by a Hough transform limited to those
angles (:func:`cv2.HoughLines`), then every place the spacing gives is looked at; the
columns are the transposed picture's rows (a grid is both). On a page ruled one way, up
to :data:`MARGINS` lines printed the other way (from edge to edge of the page within
:data:`MARGIN_EDGE`, as thick all along, and no more than twice as thick as the ruling's
lines, as a ruled line is) are its margin, taken out as well: a drawn stroke down the
page, however straight, stops short of its edges or is drawn with a wider pen. Each way
is looked at without the lines already taken out (a column crosses every line of a
ruling across it).

Each ruled line is taken out of the mask over its band (the ruling's thickness, measured
across its lines, plus a pixel each side) along its whole course to the picture's edges
(one leaving the picture askew shows a sliver there), except where the drawing's ink crosses it: a
band pixel stays ink when the drawing's ink over the line would be ink without it, or
when the drawing's ink lies just beyond the band on both sides of it (a stroke across
the line, as faint as the line). What is kept in a band must run on across it, further
than the line is thick (a vertical opening): a piece of a line beside a stroke,
darkened by its blur, does not, and would grow a spur. Crumbs of a line left apart go.
Where a stroke runs along a ruled line as faint as the line, it is lost there. Lines
whose removal would leave (nearly) no ink are the drawing itself, drawn with a ruler (a
frame with a line across it, a table), and stay.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

#: the fewest parallel lines that make a ruling
LEAST_LINES = 3
#: lines whose removal would leave less ink than this share of the mask (or these many
#: pixels) are the drawing itself — a frame with a line across, a table, a grid drawn
#: with a ruler — not its paper's ruling: a blank ruled page is traced as its lines
LEAST_LEFT = 0.01
LEAST_LEFT_PX = 16
#: a ruled line runs from edge to edge: its ink from first to last spans this share of
#: the picture at least
SPAN = 0.9
#: a leaning line is looked at where at least this share of its length is inside the
#: picture (the shares above are then of that part); at a place of a ruling found, this
#: share (the corner a line cuts off where it leaves the picture)
VISIBLE = 0.25
VISIBLE_KNOWN = 0.1
#: ... and it is printed: as thick, within a pixel, along this share of its ink
UNIFORM = 0.5
#: ... or, at a place of a ruling found, as thick as its lines along this share
ALONG = 0.1
#: a page ruled one way has at most this many margin lines the other way
MARGINS = 3
#: a margin line is printed from edge to edge of the page: its ink begins and ends within
#: this share of the picture's length from its edges (a drawn stroke down the page, as
#: straight and as even, stops short of them)
MARGIN_EDGE = 0.03
#: a ruling has a line at this share of the places its spacing gives, at least
FILLED = 0.8
#: where the spacing puts a line, ink along this share of the picture shows one (a faint
#: or dashed line, one partly hidden under the drawing)
SEEN = 0.5
#: ruled lines lie within this angle (degrees) of the picture's rows or columns
TILT = 3.0
#: the spacings of a ruling are whole multiples of its smallest to within this share
EVEN = 0.15
#: faint ink, where ruled lines are looked for: darker than this share of the mask's
#: threshold, and than :data:`LEAST_FAINT`
FAINT = 0.5
LEAST_FAINT = 0.06
#: half the height (px) of the window a line's thickness is measured in
REACH = 6
#: ink that covers a ruled line is at least this much darker than the line
DARKER = 0.1


def drop_ruling(mask: np.ndarray, ink: np.ndarray, level: float | None
                ) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    """``mask`` (H, W) bool without the ruled lines of its paper; the ruled lines' bands
    (H, W) bool, None without a ruling; and what was taken out ('N ruled lines across',
    'N ruled lines down', '1 margin line down'). ``ink`` (H, W) is the darkness the
    mask was made from, and ``level`` its threshold
    (:func:`~inkmotion.tracing.picture.ink_threshold`). The lines are looked for in the
    faint ink as well as the mask's: a ruling lighter than the mask's threshold still
    darkens the strokes it crosses (module docstring)."""
    if level is None or not mask.any():
        return mask, None, []
    faint = (ink >= max(FAINT * level, LEAST_FAINT)) | mask
    bands = np.zeros_like(mask)
    out, said, ruled = mask, [], set()

    def take(turned: bool, find: Callable, what: str) -> float:
        nonlocal out
        # the lines taken out so far are no ink to look for the others in (a column
        # crosses every line of a ruling across: it would seem to run edge to edge)
        left = faint & ~(bands & ~out)
        lines, thick = find(left.T if turned else left)
        if not lines:
            return 0.0
        views = (out.T, ink.T, bands.T) if turned else (out, ink, bands)
        kept = _without_lines(*views, lines, thick, level)
        out = kept.T if turned else kept
        ruled.add(turned)
        plural = "s" * (len(lines) > 1 and what == "margin line")
        said.append(f"{len(lines)} {what}{plural} {'down' if turned else 'across'}")
        return thick

    # rows, then columns (the transposed picture's rows); the ruling's lines' thickness
    thickness = max([take(turned, _ruled_lines, "ruled lines") for turned in (False, True)])
    if not said:
        return mask, None, []
    for turned in {False, True} - ruled:  # a ruled page's margin runs across its ruling
        take(turned, lambda faint: _margin_lines(faint, thickness), "margin line")
    if out.sum() < max(LEAST_LEFT_PX, LEAST_LEFT * mask.sum()):
        return mask, None, []  # the lines are the drawing: a frame, a table, a grid
    return np.ascontiguousarray(out), bands, said


def _margin_lines(faint: np.ndarray, ruling: float
                  ) -> tuple[list[tuple[float, float, int, int]], float]:
    """At most :data:`MARGINS` printed lines along the rows of ``faint`` (as thick all
    along: :func:`_printed_line`; from edge to edge, :data:`MARGIN_EDGE`; as the ruling's
    lines, ``ruling`` px thick, are printed: a stroke far thicker is drawn), the margin of
    a page ruled the other way, and their thickness; no lines where there are more (a
    drawing's, or a ruling's that :func:`_ruled_lines` did not take)."""
    w = faint.shape[1]
    edge = MARGIN_EDGE * w
    printed = [p for p in (_printed_line(faint, m, lean) for m, lean in _long_lines(faint))
               if p is not None and p[2] <= edge and p[3] >= w - 1 - edge
               and p[4] <= 2 * ruling + 1]
    if not printed or len(printed) > MARGINS:
        return [], 0.0
    return [p[:4] for p in printed], float(np.median([p[4] for p in printed]))


def _long_lines(faint: np.ndarray) -> list[tuple[float, float]]:
    """The straight lines within :data:`TILT` of the rows of ``faint`` that hold ink over
    :data:`SEEN` of its width, found by a Hough transform limited to those angles: (row
    where each crosses the middle column, its slope), top to bottom, one per line (a
    line thicker than a pixel is found at several rows side by side)."""
    import cv2

    h, w = faint.shape
    seen = int(SEEN * w)
    if seen < 8:
        return []
    tilt = math.radians(TILT)
    found = cv2.HoughLines(faint.astype(np.uint8), 1, math.pi / 720, seen,
                           min_theta=math.pi / 2 - tilt, max_theta=math.pi / 2 + tilt)
    if found is None:
        return []
    rho, theta = found.reshape(-1, 2).T.astype(float)
    slope = -np.cos(theta) / np.sin(theta)  # y = offset + slope·x
    middle = rho / np.sin(theta) + slope * (w / 2)
    groups: list[list[int]] = []
    for i in np.argsort(middle):
        if groups and middle[i] - middle[groups[-1][-1]] <= 3.0:
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])
    return [(float(np.median(middle[g])), float(np.median(slope[g]))) for g in groups]


def _ruled_lines(faint: np.ndarray) -> tuple[list[tuple[float, float, int, int]], float]:
    """The ruled lines running along the rows of ``faint`` (the faint ink, bool): (slope,
    offset at x = 0, first column, last column) each, top to bottom, and their thickness
    (px); no lines unless the long straight lines (:func:`_long_lines`) make a ruling."""
    h, w = faint.shape
    long = _long_lines(faint)
    if len(long) < LEAST_LINES:
        return [], 0.0
    lean = float(np.median([slope for _, slope in long]))
    # lines printed across the picture, not the rows through a drawing's straight strokes;
    # a ruling's lines are alike, so one far thicker than most is a drawn stroke
    printed = []
    for m, _ in long:
        found = _printed_line(faint, m, lean)
        if found is not None:
            printed.append((m, found))
    if len(printed) < LEAST_LINES:
        return [], 0.0
    usual = float(np.median([p[4] for _, p in printed]))
    middles = [m for m, p in printed if p[4] <= 2 * usual + 1]
    lattice = _lattice(middles)
    if lattice is None:
        return [], 0.0
    # a ruling is regular: every line of it is looked for where the spacing puts one (a
    # line whose ink is broken, faint or dashed, may fall short of the transform's votes)
    unit, phase, first, last = lattice
    lines, places = [], 0
    reach = abs(lean) * w / 2  # how far a leaning line's ends are from its middle's row
    for m in np.arange(phase - unit * ((phase + reach) // unit + 1), h + reach, unit):
        places += first - 0.5 * unit <= m <= last + 0.5 * unit
        # a pixel either way: the spacing is fitted, but a line the picture's edge cuts
        # short shows only a corner's worth of itself to find it by
        found = next((f for f in (_printed_line(faint, float(m + d), lean, usual)
                                  for d in (0.0, -1.0, 1.0)) if f is not None), None)
        if found is not None:
            lines.append(found[:4])
    # a ruling fills the places between its first line and its last, which upright
    # strokes of a drawing that happen to stand evenly apart (a word's stems) do not
    if len(lines) < LEAST_LINES or len(lines) < FILLED * places:
        return [], 0.0
    return lines, usual


def _printed_line(faint: np.ndarray, middle: float, lean: float,
                  ruling: float | None = None) -> tuple[float, float, int, int, float] | None:
    """The printed line near row ``middle`` of the picture's middle column, leaning about
    ``lean`` px per column: its own (slope, offset at column 0), fitted to the middles of
    its ink, its first and last column and its thickness (px); None where there is no
    line with ink along :data:`SEEN` of the width, from edge to edge (:data:`SPAN`), as
    thick all along (:data:`UNIFORM`). At a place of a known ruling whose lines are
    ``ruling`` px thick, a line that thick along :data:`ALONG` of its ink is one (a
    drawing's stroke may run along it)."""
    h, w = faint.shape
    xs = np.arange(w)
    ys = np.rint(middle + lean * (xs - w / 2)).astype(int)
    inside = (ys >= 0) & (ys < h)  # a leaning line may leave the picture at its top or foot
    if inside.sum() < (VISIBLE if ruling is None else VISIBLE_KNOWN) * w:
        return None
    xs, ys = xs[inside], ys[inside]
    covered = (faint[np.maximum(ys - 1, 0), xs] | faint[ys, xs]
               | faint[np.minimum(ys + 1, h - 1), xs])
    if covered.sum() < SEEN * xs.size:
        return None
    found = xs[covered]
    thick, mid = _run_across(faint, xs, ys)
    inked = thick > 0
    if found[-1] - found[0] < SPAN * (xs[-1] - xs[0]) or not inked.any():
        return None
    usual = float(np.median(thick[inked])) if ruling is None else ruling
    alone = inked & (np.abs(thick - usual) <= 1)  # the line where nothing crosses it
    if alone.sum() < (UNIFORM if ruling is None else ALONG) * inked.sum() or alone.sum() < 2:
        return None
    # its own course (a page photographed bent, a lean the transform's angles round)
    slope, offset = np.polyfit(xs[alone], mid[alone], 1)
    return float(slope), float(offset), int(found[0]), int(found[-1]), usual


def _run_across(faint: np.ndarray, xs: np.ndarray, centre: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The run of ink across a line at each of its columns ``xs`` (rows ``centre``), up
    and down from its centre within :data:`REACH`: its length (0 where the line has a
    gap) and its middle row."""
    h = faint.shape[0]
    rows = centre[None, :] + np.arange(-REACH, REACH + 1)[:, None]
    inside = (rows >= 0) & (rows < h)  # beyond the picture's edge is no ink
    window = faint[np.clip(rows, 0, h - 1), xs[None, :]] & inside  # (2R+1, n)
    up = np.cumprod(window[REACH::-1], axis=0).sum(0)
    down = np.cumprod(window[REACH:], axis=0).sum(0)
    return np.maximum(up + down - 1, 0), centre + 0.5 * (down - up)


def _lattice(middles: list[float]) -> tuple[float, float, float, float] | None:
    """The even spacing most of these lines (rows, top to bottom) stand on: (spacing, a
    row of it, the first and last line on it), or None unless :data:`LEAST_LINES` of
    them, and most, stand on one (each gap a whole number of spacings, to within
    :data:`EVEN`). Each gap between neighbours is tried as the spacing, from each line;
    the spacing is then fitted to the lines on it."""
    rows = np.asarray(middles)
    best: tuple[int, float, float] | None = None
    for unit in np.diff(rows):
        if unit < 3.0:
            continue
        for anchor in rows:
            steps = (rows - anchor) / unit
            on = np.abs(steps - np.round(steps)) <= EVEN
            # as many lines as any other, on the widest such spacing (every line of a
            # ruling stands on half its spacing too, with a gap between each two)
            if best is None or on.sum() > best[0] or (on.sum() == best[0] and unit > best[1]):
                best = (int(on.sum()), float(unit), float(anchor))
    if best is None or best[0] < LEAST_LINES or best[0] < 0.6 * rows.size:
        return None
    count, unit, anchor = best
    steps = (rows - anchor) / unit
    on = np.abs(steps - np.round(steps)) <= EVEN
    # the spacing and a row of it fitted to every line on it (one gap, measured to the
    # pixel, would carry its error to the far lines of the page)
    unit, anchor = np.polyfit(np.round(steps[on]), rows[on], 1)
    return float(unit), float(anchor), float(rows[on].min()), float(rows[on].max())


def _without_lines(mask: np.ndarray, ink: np.ndarray, in_band: np.ndarray,
                   lines: list[tuple[float, float, int, int]], thick: float,
                   least: float) -> np.ndarray:
    """``mask`` with the bands of ``lines`` (along its rows, ``thick`` px thick) taken out
    but where the drawing crosses them (module docstring); the bands are marked in
    ``in_band`` (written in place), ``least`` is the mask's threshold of darkness."""
    import cv2

    h, w = mask.shape
    out = mask.copy()
    half = int(thick) // 2 + 1
    mine = np.zeros_like(mask)  # these lines' bands
    bands = []
    for slope, offset, _first, _last in lines:
        # the whole course: a printed line runs on to the picture's edges, and one leaving
        # it through a side shows there as long as its band overlaps the picture
        xs = np.arange(w)
        centre = np.rint(offset + slope * xs).astype(int)  # (n,)
        rows = centre[None, :] + np.arange(-half, half + 1)[:, None]  # (2·half + 1, n)
        ok = (rows >= 0) & (rows < h)
        rows = np.clip(rows, 0, h - 1)
        mine[rows[ok], np.broadcast_to(xs, rows.shape)[ok]] = True
        above, below = np.clip(centre - half - 1, 0, h - 1), np.clip(centre + half + 1, 0, h - 1)
        crossed = mask[above, xs] & mask[below, xs]  # a stroke on both sides of the band
        bands.append((xs, rows, ok, crossed))
    # the lines' own darkness at each distance from their centres, over all of them (most
    # of a ruling is the lines alone, even where a stroke runs along one of them); a pixel
    # is the drawing's where its ink over the line would be ink on its own, whether the
    # ink lets the line show through (1 − ink = (1 − line)(1 − own): a felt pen) or
    # covers it (an opaque ink or graphite: as dark as off the line, clearly darker than
    # the line)
    line = np.array([np.median(np.concatenate([ink[r[k][o[k]], x[o[k]]]
                                               for x, r, o, _ in bands]))
                     for k in range(2 * half + 1)])[:, None]  # (2·half + 1, 1)
    for xs, rows, ok, crossed in bands:
        seen = ink[rows, xs[None, :]]
        own = 1.0 - (1.0 - seen) / np.maximum(1.0 - line, 1e-3)
        drawn = (own >= least) | ((seen >= least) & (seen >= line + DARKER))
        keep = mask[rows, xs[None, :]] & (crossed[None, :] | drawn)
        out[rows[ok], np.broadcast_to(xs, rows.shape)[ok]] = keep[ok]
    # ink kept in a band belongs to a stroke that crosses it, which runs on across the
    # band: what reaches no further than the band's own height (a line's piece beside a
    # stroke, darkened by its blur) is a burr the skeleton would grow a spur from
    across = cv2.morphologyEx(out.astype(np.uint8), cv2.MORPH_OPEN,
                              np.ones((int(thick) + 2, 1), np.uint8)).astype(bool)
    out = np.where(mine, out & across, out)
    in_band |= mine
    return _without_crumbs(out, in_band, half)


def _without_crumbs(mask: np.ndarray, in_band: np.ndarray, half: int) -> np.ndarray:
    """``mask`` without the crumbs of the lines: pieces of ink wholly inside the bands
    (``in_band``) and no longer than twice their height, where the drawing's blur
    darkened a line beside a stroke."""
    import cv2

    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), 8)
    height = 2 * half + 1
    small = np.flatnonzero(stats[:, cv2.CC_STAT_AREA] <= 2 * height * height)
    small = small[small > 0]  # 0: the paper
    if not small.size:
        return mask
    outside = np.bincount(labels[~in_band & mask], minlength=count)
    crumbs = small[outside[small] == 0]
    return mask & ~np.isin(labels, crumbs)
