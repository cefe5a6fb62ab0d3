"""The page in a photo of one lying on a desk: what lies around it is left out of the ink.

A phone photo of a sketch often shows the desk round the page. Against its own dark
tone a desk's grain, seams and JPEG noise are as dark as ink, so each would be traced
as strokes; and where the desk fills much of the photo it can even make the page look
like light ink on dark paper. So before anything else the page is looked for, and only
what lies on it is ink.

The page is the largest light region of the picture's *paper* (the grey, thin light
lines such as a cutting mat's grid taken out by a small opening (:data:`THIN_LIGHT`),
its strokes removed by a closing over a window wider than any stroke, the picture
carried on past its border so that a strip of desk along it stays; at most
:data:`WORK_SIDE` px across),
together with the light regions at least :data:`TOGETHER` as large (an open notebook's
two pages, apart across the gutter's shadow), when it is what no drawing, light or
shadow on a page is:

- **large**: at least :data:`LEAST_AREA` of the picture, leaving at least
  :data:`LEAST_AROUND` of it outside, and that surround wider than any stroke (a line
  drawn along the picture's border is no desk);
- **a sheet**: convex (a sheet seen in perspective is a convex quadrilateral, its
  corners perhaps curled): its area at least :data:`CONVEX` of its convex hull;
- **cornered**: two of its edges inside the picture, each at least :data:`EDGE_LENGTH`
  of the picture's shorter side long, turn by :data:`CORNER` or more (a corner of the sheet is in
  view; a hard shadow across a page has one edge, straight or curved);
- **edged**: where its outline lies inside the picture, the surround just beyond it
  (:data:`EDGE_REACH` of the picture's size out) is at most :data:`DARKER` of the
  paper just inside, on the median of the outline; light falling off across a page, or
  a vignette, changes by a few per cent over that reach;
- **not crossed**: no more than :data:`CROSSINGS` of the drawing's lines run on across
  its outline into the surround (a shadow falling across the drawing is crossed by the
  strokes it darkens; the edge of a sheet is not, since no ink lies beyond it);
- **solid**: the surround's tone, joined to the surround, reaches into at most
  :data:`SOLID` of its interior in the picture itself (before the closing). A block of
  bold black letters on white paper is, in the inverted picture, a light convex
  "sheet" once the closing has bridged the gaps between the letters, but the white
  paper runs on into those gaps; a sheet's own tone is unbroken there (an open
  notebook's gutter is about 2 % of its pages).

The page is then the convex hull of that region, drawn in the picture's own pixels and
shrunk by the reach (the edge's blur and the sheet's own shadow), and everything outside
it is paper. A light page is looked for; a dark page on a lighter desk (white ink on
black paper, or ``--invert``) is the light page of the inverted picture
(:func:`inkmotion.tracing.picture.read_picture` looks for both).
"""

from __future__ import annotations

import math

import numpy as np

#: the page is looked for at this size (px, the longer side) at most
WORK_SIDE = 512
#: light lines on the desk up to this wide (px at the working size) are no page: a
#: cutting mat's grid, a table's seams (the gaps between a drawing's strokes are wider)
THIN_LIGHT = 7
#: the page covers at least this share of the picture ...
LEAST_AREA = 0.2
#: ... and leaves at least this share of it around the page
LEAST_AROUND = 0.02
#: the page's region is at least this share of its convex hull
CONVEX = 0.9
#: just beyond the page's outline the surround is at most this share of the paper's grey
DARKER = 0.7
#: the reach (share of the picture's longer side) over which the edge is looked at, and
#: by which the page is shrunk
EDGE_REACH = 0.012
#: a page's outline is crossed by at most this many lines of ink
CROSSINGS = 1
#: darkness against the local paper that counts as ink when crossings are counted
CROSSING_INK = 0.25
#: light regions at least this share of the largest's area are the page with it (the two
#: pages of an open notebook): the page is then their hull, if they make a convex whole
TOGETHER = 0.25
#: a page's edges inside the picture are at least this share of its shorter side long ...
EDGE_LENGTH = 0.1
#: ... and two of them meet at a corner: their directions differ by this much (degrees)
CORNER = 45.0
#: the surround's tone, joined to it, reaches into at most this share of the page's
#: interior (bold letters' gaps: a quarter of their block; a notebook's gutter: 2 %)
SOLID = 0.1


def find_page(grey: np.ndarray, widest: float) -> np.ndarray | None:
    """The page (H, W) bool of a picture ``grey`` (H, W) in [0, 1] of dark ink on light
    paper, or None where there is none to find (module docstring); ``widest`` (px) is the
    widest stroke of line art on the picture
    (:func:`inkmotion.tracing.picture.widest_stroke`)."""
    import cv2

    h, w = grey.shape
    f = max(1.0, max(h, w) / WORK_SIDE)
    small = cv2.resize(grey, (max(1, round(w / f)), max(1, round(h / f))),
                       interpolation=cv2.INTER_AREA) if f > 1 else grey
    k = (int(2.4 * widest / f) + 3) | 1  # wider than any stroke, as the paper estimate's
    calm = cv2.medianBlur(small, 5)
    # a small opening takes thin light lines (a cutting mat's grid) out of the desk; then
    # the picture is carried on outward past its border, so that a strip of desk along
    # it is no narrow dark stroke for the closing to fill
    thin = cv2.getStructuringElement(cv2.MORPH_RECT, (THIN_LIGHT, THIN_LIGHT))
    wide = cv2.copyMakeBorder(cv2.morphologyEx(calm, cv2.MORPH_OPEN, thin), k, k, k, k,
                              cv2.BORDER_REPLICATE)
    paper = cv2.morphologyEx(wide, cv2.MORPH_CLOSE,
                             cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))[k:-k, k:-k]
    region = _light_region(paper)
    if region is None:
        return None
    contours = cv2.findContours(region.astype(np.uint8), cv2.RETR_EXTERNAL,
                                cv2.CHAIN_APPROX_NONE)[0]
    hull = cv2.convexHull(np.concatenate(contours))
    hull_area = cv2.contourArea(hull)
    area = float(region.sum())
    if not (LEAST_AREA * region.size <= area and hull_area <= (1 - LEAST_AROUND) * region.size
            and area >= CONVEX * hull_area):
        return None
    if not _has_a_corner(hull, small.shape):
        return None
    sheet = np.zeros(small.shape, np.uint8)  # the hull, filled
    cv2.fillPoly(sheet, [hull.reshape(-1, 2)], 1)
    beyond = cv2.distanceTransform(1 - sheet, cv2.DIST_L2, 3)
    if float(beyond.max()) * f < widest:  # a stroke along the border, not a desk
        return None
    reach = max(2.0, EDGE_REACH * max(small.shape))
    sides = _either_side(hull, reach, small.shape)
    if sides is None:
        return None
    inside, outside = sides
    surround = float(np.median(paper[outside[0], outside[1]]))
    sheet_tone = float(np.median(paper[inside[0], inside[1]]))
    if surround > DARKER * sheet_tone:
        return None
    dark = 1.0 - calm / np.maximum(paper, 1e-3) > CROSSING_INK
    bands = _deep_in_and_far_out(sheet, reach)
    if _crossings(dark, *bands) > CROSSINGS:
        return None
    if _surround_within(calm < 0.5 * (surround + sheet_tone), *bands) > SOLID:
        return None
    page = np.zeros((h, w), np.uint8)
    cv2.fillPoly(page, [np.round(hull.reshape(-1, 2) * f).astype(np.int32)], 1)
    shrink = int(math.ceil(reach * f))
    page = cv2.erode(page, cv2.getStructuringElement(cv2.MORPH_ELLIPSE,
                                                     (2 * shrink + 1, 2 * shrink + 1)))
    return page.astype(bool)


def _has_a_corner(hull: np.ndarray, shape: tuple[int, int]) -> bool:
    """Whether two long edges of the outline ``hull`` that lie inside the picture (not
    along its border) turn by :data:`CORNER` or more from each other: a page's corner. A
    hard shadow across a page has one straight or curved edge, no corner."""
    import cv2

    h, w = shape
    poly = cv2.approxPolyDP(hull, 0.01 * cv2.arcLength(hull, True), True).reshape(-1, 2)
    angles = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        on_border = any(abs(float(a[i]) - edge) <= 1.5 and abs(float(b[i]) - edge) <= 1.5
                        for i, edge in ((0, 0), (0, w - 1), (1, 0), (1, h - 1)))
        if not on_border and np.hypot(*(b - a).astype(float)) >= EDGE_LENGTH * min(h, w):
            angles.append(math.degrees(math.atan2(float(b[1] - a[1]), float(b[0] - a[0]))))
    for i, x in enumerate(angles):
        for y in angles[i + 1:]:
            turn = abs((x - y + 180.0) % 360.0 - 180.0)
            if CORNER <= turn <= 180.0 - CORNER:
                return True
    return False


def _light_region(paper: np.ndarray) -> np.ndarray | None:
    """The largest connected region of the light side of ``paper`` (Otsu's threshold of
    its tones) with those at least :data:`TOGETHER` as large, their holes filled; None for
    a paper of one tone."""
    import cv2
    from skimage.filters import threshold_otsu

    if float(paper.max() - paper.min()) < 0.1:
        return None
    tone = np.log(np.maximum(paper, 1e-3))  # light falls off by a factor, not a step
    light = (tone > threshold_otsu(tone)).astype(np.uint8)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(light, connectivity=8)
    if count < 2:
        return None
    areas = stats[1:, cv2.CC_STAT_AREA]
    # a notebook's two pages, apart across the gutter's shadow, are one page together
    region = np.isin(labels, 1 + np.flatnonzero(areas >= TOGETHER * areas.max())).astype(
        np.uint8)
    contours = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)[0]
    filled = np.zeros_like(region)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    return filled.astype(bool)


def _either_side(hull: np.ndarray, reach: float, shape: tuple[int, int]
                 ) -> tuple[np.ndarray, np.ndarray] | None:
    """The places (2, K) of rows and columns ``reach`` px inside and outside the outline
    ``hull`` (convex, from :func:`cv2.convexHull`), a pair a pixel along it, where both
    lie in the picture (the page's edges on the picture's border have no surround to
    look at); None when fewer than a tenth of the outline has a pair."""
    pts = hull.reshape(-1, 2).astype(float)
    a, b = pts, np.roll(pts, -1, axis=0)  # each edge a → b
    length = np.hypot(*(b - a).T)
    normal = np.stack((b[:, 1] - a[:, 1], a[:, 0] - b[:, 0]), 1)
    normal /= np.maximum(length, 1e-9)[:, None]
    outward = np.einsum("ij,ij->i", normal, (a + b) / 2 - pts.mean(axis=0)) >= 0
    normal = np.where(outward[:, None], normal, -normal)  # out of the page
    counts = length.astype(int)  # a place a pixel along each edge
    edge = np.repeat(np.arange(len(pts)), counts)
    if edge.size == 0:
        return None
    step = np.arange(edge.size) - (np.cumsum(counts) - counts)[edge]
    along = a[edge] + (step / counts[edge])[:, None] * (b - a)[edge]
    out = np.round(along + reach * normal[edge]).astype(int)
    inn = np.round(along - reach * normal[edge]).astype(int)
    h, w = shape
    seen = ((out[:, 0] >= 0) & (out[:, 0] < w) & (out[:, 1] >= 0) & (out[:, 1] < h)
            & (inn[:, 0] >= 0) & (inn[:, 0] < w) & (inn[:, 1] >= 0) & (inn[:, 1] < h))
    if seen.sum() < 0.1 * edge.size:
        return None
    return inn[seen][:, ::-1].T, out[seen][:, ::-1].T


def _deep_in_and_far_out(sheet: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) bool each: the places more than ``reach`` px inside the outline of ``sheet``
    (H, W) uint8, the filled hull, and those more than ``reach`` px outside it."""
    import cv2

    r = max(1, int(round(reach)))
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return cv2.erode(sheet, disc).astype(bool), ~cv2.dilate(sheet, disc).astype(bool)


def _surround_within(surround: np.ndarray, deep_in: np.ndarray, far_out: np.ndarray
                     ) -> float:
    """The share of a page's interior ``deep_in`` (:func:`_deep_in_and_far_out`) that has
    the surround's tone (``surround``, (H, W) bool) and is joined to the surround
    ``far_out``: the gaps between bold strokes that a closing bridged into one light block
    (module docstring, *solid*)."""
    import cv2

    _, labels = cv2.connectedComponents(surround.astype(np.uint8), connectivity=8)
    joined = np.unique(labels[far_out & surround])
    within = deep_in & np.isin(labels, joined[joined > 0])
    return float(within.sum()) / max(int(deep_in.sum()), 1)


def _crossings(dark: np.ndarray, deep_in: np.ndarray, far_out: np.ndarray) -> int:
    """How many pieces of ink (``dark``, (H, W) bool) reach both a page's interior
    ``deep_in`` and the surround ``far_out`` (:func:`_deep_in_and_far_out`): lines that
    run on across its outline."""
    import cv2

    _, labels = cv2.connectedComponents(dark.astype(np.uint8), connectivity=8)
    across = np.intersect1d(np.unique(labels[deep_in & dark]),
                            np.unique(labels[far_out & dark]))
    return int((across > 0).sum())
