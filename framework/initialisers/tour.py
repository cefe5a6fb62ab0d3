"""A short closed tour through 2-D points (the travelling salesman problem), and the one
open path it becomes: TSP-art (Kaplan & Bosch 2005) connects stipples into a single line.

Solvers (``solve_tour``), each returning a closed cycle as a permutation of the points:

- ``fast-tsp`` (default): fast_tsp's Rust local search with perturbation (Lin–Kernighan
  steps over LKH-style α-nearness candidates when they fit the budget) under a wall-clock
  budget ``time_limit``, single-threaded. Its matrix must be uint16, so distances are scaled to
  ≤ 65 535 (≈ 0.01 px on a 512-px canvas).
- ``elkai``: LKH, Helsgaun's Lin–Kernighan heuristic, ``runs`` restarts (TSPLIB ``EUC_2D``
  on coordinates × 100, so LKH's integer rounding is 0.01 px). Deterministic (fixed seed).
- ``ortools``: OR-Tools routing, cheapest-arc start and guided local search under
  ``time_limit`` (integer distances × 100).
- ``2-opt``: the reference here, nearest-neighbour start then 2-opt to a local optimum
  (Croes 1958), numpy-vectorised; for tests and comparison.

Why fast-tsp (:mod:`inkmotion.benchmarks.tsp`: stipples of the astronaut's saliency at
512 px, 2 CPU cores; tour length / the shortest found, wall time):

    solver     n=150          n=500          n=1000         n=2000
    fast-tsp   1.0000 0.50 s  1.0000 0.50 s  1.0002 0.55 s  1.0011 0.82 s   (0.5 s budget)
    elkai      1.0000 0.06 s  1.0000 1.15 s  1.0000 9.17 s  1.0000 43.5 s   (1 run)
    ortools    1.0169 0.56 s  1.0639 0.52 s  1.1224 0.56 s  1.1793 1.06 s   (0.5 s GLS)
    2-opt      1.0692 0.01 s  1.0470 0.04 s  1.0361 0.15 s  1.0444 0.59 s

LKH (elkai) finds the shortest tours, but its time grows steeply with n (43 s at 2000
points; the abstract job allows 5000). fast-tsp is within 0.11 % of it at every size in a
fixed half second. OR-Tools' guided local search (the authors' solver) is 2–18 % longer in
the same time (still 2–12 % with 5 s), and 2-opt 4–7 % longer. The price of a time budget:
above a few hundred points the tour depends on how much search fits in it (tours of equal
length ± 0.1 %, not identical between runs); at the paper's 150 points fast-tsp converges
in < 0.05 s, long before the budget, and its tour repeats (written one way:
:func:`canonical_cycle`, for its start and direction vary from run to run). Use
``elkai`` where a large tour must reproduce exactly.
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np

from inkmotion.errors import SpecError

SOLVERS = ("fast-tsp", "elkai", "ortools", "2-opt")
DEFAULT_SOLVER = "fast-tsp"
#: time budget (s) of the solvers that have one (fast-tsp, ortools)
DEFAULT_TIME_LIMIT = 0.5
#: elkai: LKH runs (restarts); elkai's default is 10, one gave the same tours (150 and 500
#: points) 8× faster
DEFAULT_RUNS = 1


def distance_matrix(points: np.ndarray) -> np.ndarray:
    """Euclidean distances (n, n) between points (n, 2)."""
    p = np.asarray(points, dtype=np.float64)
    return np.hypot(p[:, None, 0] - p[None, :, 0], p[:, None, 1] - p[None, :, 1])


def tour_length(points: np.ndarray, order: np.ndarray, closed: bool = True) -> float:
    """Length of the polyline through ``points[order]``, back to the start if ``closed``."""
    p = np.asarray(points, dtype=np.float64)[np.asarray(order)]
    if closed:
        p = np.vstack((p, p[:1]))
    return float(np.sum(np.hypot(*np.diff(p, axis=0).T)))


def nearest_neighbour_tour(points: np.ndarray, start: int = 0) -> np.ndarray:
    """Greedy tour: from ``start``, always go to the nearest unvisited point."""
    d = distance_matrix(points)
    n = d.shape[0]
    order = np.empty(n, dtype=np.int64)
    visited = np.zeros(n, dtype=bool)
    cur = start
    for k in range(n):
        order[k], visited[cur] = cur, True
        if k + 1 < n:
            cur = int(np.argmin(np.where(visited, np.inf, d[cur])))
    return order


def two_opt(points: np.ndarray, order: np.ndarray | None = None,
            max_passes: int = 1000) -> np.ndarray:
    """2-opt local search (Croes 1958) of a closed tour, from ``order`` (default: nearest
    neighbour): replace edges (a, b), (c, d) by (a, c), (b, d) — reversing b..c — while
    that shortens the tour; for each a the best c is applied (vectorised over c)."""
    d = distance_matrix(points)
    n = d.shape[0]
    tour = nearest_neighbour_tour(points) if order is None else np.array(order, dtype=np.int64)
    if n < 4:
        return tour
    for _ in range(max_passes):
        improved = False
        for i in range(n - 2):
            a, b = tour[i], tour[i + 1]
            c = tour[i + 2:]  # (k,) candidates; j = i + 2 + index
            nxt = tour[np.r_[i + 3:n, 0]]  # successor of each c (wrapping)
            gain = d[a, b] + d[c, nxt] - d[a, c] - d[b, nxt]
            if i == 0:
                gain[-1] = 0.0  # the edge (c, d) = (last, first) shares a with (a, b)
            k = int(np.argmax(gain))
            if gain[k] > 1e-9:
                j = i + 2 + k
                tour[i + 1:j + 1] = tour[i + 1:j + 1][::-1].copy()
                improved = True
        if not improved:
            break
    return tour


def _solver_module(name: str, package: str, solver: str) -> Any:
    """``import name``, or a :class:`SpecError` saying which package the solver needs."""
    try:
        return importlib.import_module(name)
    except ImportError:
        raise SpecError(f"The TSP solver {solver!r} needs the {package} package; install it "
                        f"or choose the solver {DEFAULT_SOLVER!r}.") from None


def _elkai(points: np.ndarray, runs: int) -> np.ndarray:
    elkai = _solver_module("elkai", "elkai", "elkai")

    coords = {str(i): (float(x) * 100.0, float(y) * 100.0) for i, (x, y) in enumerate(points)}
    names = elkai.Coordinates2D(coords).solve_tsp(runs=runs)[:-1]  # closed: drop the return
    return np.array([int(k) for k in names], dtype=np.int64)


def _fast_tsp(points: np.ndarray, time_limit: float) -> np.ndarray:
    fast_tsp = _solver_module("fast_tsp", "fast-tsp", "fast-tsp")

    d = distance_matrix(points)
    scale = 65535.0 / max(float(d.max()), 1e-9)
    dists = np.rint(d * scale).astype(np.int64)
    tour = fast_tsp.find_tour(dists, duration_seconds=time_limit, max_threads=1)
    return np.array(tour, dtype=np.int64)


def _ortools(points: np.ndarray, time_limit: float) -> np.ndarray:
    pywrapcp = _solver_module("ortools.constraint_solver.pywrapcp", "ortools", "ortools")
    routing_enums_pb2 = _solver_module("ortools.constraint_solver.routing_enums_pb2", "ortools",
                                       "ortools")

    n = len(points)
    dists = np.rint(distance_matrix(points) * 100.0).astype(np.int64)
    manager = pywrapcp.RoutingIndexManager(n, 1, 0)
    routing = pywrapcp.RoutingModel(manager)
    transit = routing.RegisterTransitMatrix(dists.tolist())
    routing.SetArcCostEvaluatorOfAllVehicles(transit)
    search = pywrapcp.DefaultRoutingSearchParameters()
    search.first_solution_strategy = routing_enums_pb2.FirstSolutionStrategy.PATH_CHEAPEST_ARC
    search.local_search_metaheuristic = (
        routing_enums_pb2.LocalSearchMetaheuristic.GUIDED_LOCAL_SEARCH)
    search.time_limit.FromMilliseconds(max(1, round(time_limit * 1000)))
    solution = routing.SolveWithParameters(search)
    assert solution is not None, "OR-Tools found no tour"
    order, index = [], routing.Start(0)
    while not routing.IsEnd(index):
        order.append(manager.IndexToNode(index))
        index = solution.Value(routing.NextVar(index))
    return np.array(order, dtype=np.int64)


def solve_tour(points: np.ndarray, solver: str = DEFAULT_SOLVER, *,
               time_limit: float = DEFAULT_TIME_LIMIT, runs: int = DEFAULT_RUNS) -> np.ndarray:
    """A short closed tour through ``points`` (n, 2): a permutation (n,) of 0..n−1.

    ``time_limit`` (s) bounds fast-tsp and ortools; ``runs`` is elkai's LKH restarts.
    """
    p = np.asarray(points, dtype=np.float64)[:, :2]
    n = p.shape[0]
    if n <= 3:  # every cycle through ≤ 3 points has the same length
        return np.arange(n, dtype=np.int64)
    if solver == "elkai":
        order = _elkai(p, runs)
    elif solver == "fast-tsp":
        order = _fast_tsp(p, time_limit)
    elif solver == "ortools":
        order = _ortools(p, time_limit)
    elif solver == "2-opt":
        order = two_opt(p)
    else:
        raise ValueError(f"unknown TSP solver {solver!r}; one of {SOLVERS}")
    assert sorted(order.tolist()) == list(range(n)), f"{solver} returned no permutation"
    return canonical_cycle(order)


def canonical_cycle(order: np.ndarray) -> np.ndarray:
    """The closed tour ``order`` written one way only: from point 0, towards the smaller of
    its two neighbours. A solver may return the same cycle from any start and in either
    direction (fast-tsp does, run to run), which opened into a path put the stroke's start
    at its other end: the same job gave another plan."""
    order = np.roll(np.asarray(order, dtype=np.int64), -int(np.argmin(order)))
    if order.size > 2 and order[1] > order[-1]:
        order = np.concatenate([order[:1], order[:0:-1]])
    return order


def open_cycle(points: np.ndarray, order: np.ndarray) -> np.ndarray:
    """The closed tour ``order`` opened into one path by removing its longest edge: the
    path starts at the far end of that edge and ends at its near end."""
    order = np.asarray(order, dtype=np.int64)
    if order.size < 2:
        return order
    p = np.asarray(points, dtype=np.float64)[order]
    edges = np.hypot(*(np.roll(p, -1, axis=0) - p).T)  # edge k: order[k] -> order[k+1]
    k = int(np.argmax(edges))
    return np.roll(order, -(k + 1))


def tsp_path(points: np.ndarray, solver: str = DEFAULT_SOLVER, *,
             time_limit: float = DEFAULT_TIME_LIMIT, runs: int = DEFAULT_RUNS) -> np.ndarray:
    """The order (n,) of one open path through all ``points``: a short tour with its
    longest edge removed."""
    return open_cycle(points, solve_tour(points, solver, time_limit=time_limit, runs=runs))
