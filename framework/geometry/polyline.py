"""Polylines as arrays (n, ≥2): the plain measures every module that walks one shares."""

from __future__ import annotations

import numpy as np


def arc_length(polyline: np.ndarray) -> np.ndarray:
    """Arc length (n,) px at each vertex of ``polyline`` (n, ≥2; x, y count), 0 at the
    first: the running sum of the planar steps between vertices, in the polyline's own
    dtype."""
    xy = np.asarray(polyline)[:, :2]
    return np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))
