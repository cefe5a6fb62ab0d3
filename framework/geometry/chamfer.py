"""Symmetric Chamfer (and Hausdorff) distance between two drawings given as polylines.

Both sets are densified to points every ``spacing`` px along each polyline (vertices
kept), A and B. With d(p, Q) = min_{q ∈ Q} |p − q| (a cKDTree query):

    mean = ½ (mean_{a ∈ A} d(a, B) + mean_{b ∈ B} d(b, A))     (symmetric Chamfer, px)
    max  = max(max_{a ∈ A} d(a, B), max_{b ∈ B} d(b, A))         (Hausdorff, px)

Densifying makes the measure a distance between curves rather than between vertex sets,
up to an error of at most spacing/2. Only the first two columns (x, y) are used.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def densify(polyline: np.ndarray, spacing: float = 0.25) -> np.ndarray:
    """Points (k, 2) along ``polyline`` (n, ≥2) at most ``spacing`` px apart, vertices kept."""
    p = np.asarray(polyline, dtype=np.float64)[:, :2]
    if len(p) < 2:
        return p
    seg = np.diff(p, axis=0)  # (n−1, 2)
    pieces = np.maximum(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / spacing), 1).astype(np.int64)
    start = np.repeat(np.arange(len(seg)), pieces)  # segment of every new point
    offset = np.arange(pieces.sum()) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    frac = (offset / pieces[start])[:, None]
    return np.vstack((p[start] + frac * seg[start], p[-1:]))


def _points(polylines: list[np.ndarray], spacing: float) -> np.ndarray:
    pts = [densify(p, spacing) for p in polylines if len(p) > 0]
    assert pts, "at least one non-empty polyline"
    return np.vstack(pts)


def chamfer(
    a: list[np.ndarray], b: list[np.ndarray], spacing: float = 0.25
) -> tuple[float, float]:
    """(mean, max): symmetric Chamfer distance and Hausdorff distance in px between the
    polyline sets ``a`` and ``b`` (each a list of (n, ≥2) arrays), densified at ``spacing``."""
    assert spacing > 0, spacing
    pa, pb = _points(a, spacing), _points(b, spacing)
    d_ab, _ = cKDTree(pb).query(pa)
    d_ba, _ = cKDTree(pa).query(pb)
    mean = 0.5 * (float(d_ab.mean()) + float(d_ba.mean()))
    return mean, float(max(d_ab.max(), d_ba.max()))
