"""TSP-art initialisation (Kaplan & Bosch 2005), as the paper's image abstraction starts.

Weighted Voronoi stipples of the saliency map (:mod:`inkmotion.initialisers.stippling`)
joined by a short tour (:mod:`inkmotion.initialisers.tour`) that is opened into one path at
its longest edge: the virtual targets of a single motor plan that visits every salient
region once. The paper uses 150 targets.
"""

from __future__ import annotations

import numpy as np

from inkmotion.initialisers.stippling import (
    DEFAULT_FLOOR,
    DEFAULT_GAMMA,
    DEFAULT_ITERATIONS,
    DEFAULT_POINTS,
    density_from_saliency,
    stipple,
)
from inkmotion.initialisers.tour import DEFAULT_SOLVER, DEFAULT_TIME_LIMIT, tsp_path


def tsp_art_path(saliency: np.ndarray, canvas: tuple[float, float],
                 points: int = DEFAULT_POINTS, *, rng: np.random.Generator,
                 iterations: int = DEFAULT_ITERATIONS, gamma: float = DEFAULT_GAMMA,
                 floor: float = DEFAULT_FLOOR, solver: str = DEFAULT_SOLVER,
                 time_limit: float = DEFAULT_TIME_LIMIT) -> np.ndarray:
    """The ordered stipples (n, 2), canvas px (x right, y down), of one open TSP path
    through ``points`` weighted-Voronoi stipples of ``saliency`` (H, W) in [0, 1].

    ``canvas`` (W, H) px: stipples in map px are scaled by canvas / map size (the identity
    when the map has the canvas's size, as a job makes it).
    """
    s = np.asarray(saliency, dtype=np.float64)
    density = density_from_saliency(s, gamma, floor)
    p = stipple(density, points, rng=rng, iterations=iterations).points
    h, w = s.shape
    p = p * np.array([canvas[0] / w, canvas[1] / h])
    return p[tsp_path(p, solver, time_limit=time_limit)]
