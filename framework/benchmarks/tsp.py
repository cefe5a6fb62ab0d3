"""Benchmark of the TSP solvers behind the 'voronoi-tsp' initialiser.

Points: n ∈ {150 (the paper's), 500, 1000, 2000} weighted-Voronoi stipples of the default
'spectral' saliency (OpenCV fine-grained) of skimage's astronaut at 512 px (or, without
scikit-image, of a synthetic map of Gaussian blobs), seed 0. Each solver of
:mod:`inkmotion.initialisers.tour` finds a closed tour; the figures are its length relative
to the shortest tour any solver found on the same points (1.000 = best) and its wall time.
fast-tsp and OR-Tools run under the initialiser's time budget (0.5 s), elkai (LKH) for one
run, 2-opt to a local optimum. elkai takes minutes at 2000 points.

Run ``python -m inkmotion.benchmarks.tsp`` for the table.
"""

from __future__ import annotations

import time

import numpy as np

from inkmotion.initialisers.stippling import density_from_saliency, stipple
from inkmotion.initialisers.tour import DEFAULT_TIME_LIMIT, SOLVERS, solve_tour, tour_length

SIZES = (150, 500, 1000, 2000)
MAP_SIDE = 512


def benchmark_map(side: int = MAP_SIDE) -> np.ndarray:
    """Saliency (side, side) in [0, 1]: the astronaut's default saliency, or blobs."""
    try:
        import cv2
        import torch
        from skimage import data

        from inkmotion.saliency.spectral import spectral_saliency

        rgb = cv2.resize(data.astronaut(), (side, side), interpolation=cv2.INTER_AREA)
        image = torch.from_numpy(rgb).permute(2, 0, 1).float() / 255
        return spectral_saliency(image).numpy().astype(np.float64)
    except ImportError:
        rng = np.random.default_rng(0)
        yy, xx = np.mgrid[0:side, 0:side] + 0.5
        s = np.zeros((side, side))
        for cx, cy, r in rng.uniform([0, 0, 0.03 * side], [side, side, 0.15 * side], (8, 3)):
            s += np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * r * r))
        return s / s.max()


def bench_tsp(sizes: tuple[int, ...] = SIZES, solvers: tuple[str, ...] = SOLVERS,
              time_limit: float = DEFAULT_TIME_LIMIT,
              saliency: np.ndarray | None = None) -> dict[str, float]:
    """Figures ``tsp_{solver}_{n}_rel`` (tour length / best length on those points) and
    ``tsp_{solver}_{n}_s`` (wall seconds), plus ``stipple_{n}_s`` (stippling seconds)."""
    density = density_from_saliency(benchmark_map() if saliency is None else saliency)
    figures: dict[str, float] = {}
    for n in sizes:
        t0 = time.perf_counter()
        points = stipple(density, n, rng=np.random.default_rng(0)).points
        figures[f"stipple_{n}_s"] = time.perf_counter() - t0
        lengths = {}
        for solver in solvers:
            t0 = time.perf_counter()
            order = solve_tour(points, solver, time_limit=time_limit)
            figures[f"tsp_{solver}_{n}_s"] = time.perf_counter() - t0
            lengths[solver] = tour_length(points, order)
        best = min(lengths.values())
        for solver, length in lengths.items():
            figures[f"tsp_{solver}_{n}_rel"] = length / best
    return figures


def format_table(figures: dict[str, float], sizes: tuple[int, ...] = SIZES,
                 solvers: tuple[str, ...] = SOLVERS) -> str:
    """The figures as a text table: one row per solver, length ratio and time per size."""
    head = f"{'solver':<10}" + "".join(f"{f'n={n}':>22}" for n in sizes)
    rows = [head, f"{'':<10}" + "".join(f"{'length/best    time':>22}" for _ in sizes)]
    for solver in solvers:
        cells = "".join(f"{figures[f'tsp_{solver}_{n}_rel']:>13.4f}"
                        f"{figures[f'tsp_{solver}_{n}_s']:>8.2f}s" for n in sizes)
        rows.append(f"{solver:<10}" + cells)
    rows.append(f"{'stipple':<10}" + "".join(f"{'':>13}{figures[f'stipple_{n}_s']:>8.2f}s"
                                               for n in sizes))
    return "\n".join(rows)


if __name__ == "__main__":
    print(format_table(bench_tsp()))
