"""Initialiser "voronoi-tsp": TSP-art, the paper's start for image abstraction.

``points`` weighted-Voronoi stipples (Secord 2002) of the job's saliency map, density
saliency^γ + floor, ``iterations`` Lloyd rounds, joined by a short TSP tour (fast-tsp by
default) opened at its longest edge: ONE motor plan through all of them (m = points − 1,
Δt = 1, δ = 0). The paper's path has 150 "virtual targets", read here as 150 points. The
number of points is the ``points`` option when given, else the job's ``targets``
(``JobInputs.targets``), else 150. See :mod:`inkmotion.initialisers.stippling` and
:mod:`inkmotion.initialisers.tour` (which also says why fast-tsp).

Randomness: the stipples' start is drawn from ``np.random.default_rng(seed)``; with no
``seed`` (the default) that seed is drawn from torch's global generator, which the job
shell seeds from the job's seed, so a job's seed decides the initialisation and
``seed`` pins it independently of the job.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.initialisers.stippling import (
    DEFAULT_FLOOR,
    DEFAULT_GAMMA,
    DEFAULT_ITERATIONS,
    DEFAULT_POINTS,
    DEFAULT_TOL,
)
from inkmotion.initialisers.tour import DEFAULT_SOLVER, DEFAULT_TIME_LIMIT, SOLVERS
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import Initialiser, JobInputs
    from inkmotion.sigma_lognormal.plan import MotorPlan


@dataclass
class VoronoiTspOptions:
    """Options of the 'voronoi-tsp' initialiser."""

    points: int | None = param(None, "Stipples, the points of the path (default: the job's "
                               f"targets, else {DEFAULT_POINTS}, the paper's).",
                               minimum=2, maximum=20_000)
    iterations: int = param(DEFAULT_ITERATIONS, "Lloyd iterations at most (stops earlier "
                            f"when the points move < {DEFAULT_TOL} px on average).",
                            minimum=0, maximum=1000)
    gamma: float = param(DEFAULT_GAMMA, "Density = saliency^gamma + floor.", minimum=0.0,
                         maximum=10.0)
    floor: float = param(DEFAULT_FLOOR, "Density floor, so blank regions keep some points.",
                         minimum=1e-6, maximum=1.0)
    solver: str = param(DEFAULT_SOLVER, "TSP solver.", choices=SOLVERS)
    time_limit: float = param(DEFAULT_TIME_LIMIT, "Time budget of fast-tsp / ortools, s.",
                              minimum=0.01, maximum=600.0)
    seed: int | None = param(None, "Seed of the stipples (default: drawn from the job's "
                             "seed).", minimum=0)


class VoronoiTspInitialiser:
    """One TSP-art motor plan through weighted Voronoi stipples of the saliency map."""

    name = "voronoi-tsp"
    description = ("TSP-art: `points` weighted Voronoi stipples of the saliency map joined by "
                   "a short TSP tour opened into one path; one plan (the paper: 150 targets).")
    Options = VoronoiTspOptions

    def __call__(self, inputs: JobInputs, *, width: float = 3.0, dtype: Any = None,
                 device: Any = None, points: int | None = None,
                 iterations: int = DEFAULT_ITERATIONS, gamma: float = DEFAULT_GAMMA,
                 floor: float = DEFAULT_FLOOR, solver: str = DEFAULT_SOLVER,
                 time_limit: float = DEFAULT_TIME_LIMIT,
                 seed: int | None = None) -> list[MotorPlan]:
        """One plan through the ordered stipples of ``inputs.saliency`` (H, W) in [0, 1],
        in ``inputs.canvas`` px; ``points`` None: ``inputs.targets``, else 150."""
        if inputs.saliency is None:
            raise SpecError("The voronoi-tsp initialiser needs a saliency map, which only an "
                            "image input gives; give an image, or use the line initialiser.")
        import numpy as np
        import torch

        from inkmotion.initialisers.voronoi_tsp import tsp_art_path
        from inkmotion.sigma_lognormal.plan import MotorPlan

        if seed is None:
            seed = int(torch.randint(0, 2**62, ()).item())
        saliency = inputs.saliency.detach().to("cpu", torch.float64).numpy()
        n = points if points is not None else inputs.targets or DEFAULT_POINTS
        if n < 2:
            raise SpecError(f"The voronoi-tsp initialiser needs at least 2 points, not {n}; "
                            "ask for more targets.")
        path = tsp_art_path(saliency, inputs.canvas, n, rng=np.random.default_rng(seed),
                            iterations=iterations, gamma=gamma, floor=floor, solver=solver,
                            time_limit=time_limit)
        return [MotorPlan.from_points(path, width=width, dtype=dtype or torch.float32,
                                      device=device)]


@hookimpl
def inkmotion_initialisers() -> list[Initialiser]:
    return [VoronoiTspInitialiser()]
