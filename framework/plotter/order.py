"""The order strokes are drawn in. By default the drawing's own (it is the motion: the
order a hand wrote it in); ``optimise`` reorders whole strokes, never reversing one (a
reversed ΣΛ stroke is another movement), to cut pen-up travel from X0 Y0 back to X0 Y0: a
greedy nearest-start tour improved by moving single strokes to the place that shortens the
tour most (or-opt, asymmetric: end of one → start of the next), until no move helps."""

from __future__ import annotations

import numpy as np


def tour_length(order: list[int], starts: np.ndarray, ends: np.ndarray) -> float:
    """mm of travel X0 Y0 → strokes in ``order`` → X0 Y0 (``starts``, ``ends``: (n, 2))."""
    here, total = np.zeros(2), 0.0
    for i in order:
        total += float(np.linalg.norm(starts[i] - here))
        here = ends[i]
    return total + float(np.linalg.norm(here))


#: above this many strokes only the greedy tour is made (or-opt is O(n³) per pass here)
MAX_IMPROVED = 150


def optimise_order(starts: np.ndarray, ends: np.ndarray, max_passes: int = 50) -> list[int]:
    """A stroke order with short pen-up travel (module docstring)."""
    n = len(starts)
    left, order, here = set(range(n)), [], np.zeros(2)
    while left:
        i = min(left, key=lambda j: float(np.linalg.norm(starts[j] - here)))
        order.append(i)
        left.remove(i)
        here = ends[i]
    best = tour_length(order, starts, ends)
    for _ in range(max_passes if n <= MAX_IMPROVED else 0):
        improved = False
        for pos in range(n):
            stroke = order[pos]
            rest = order[:pos] + order[pos + 1:]
            for at in range(n):
                if at == pos:
                    continue
                candidate = rest[:at] + [stroke] + rest[at:]
                length = tour_length(candidate, starts, ends)
                if length < best - 1e-9:
                    order, best, improved = candidate, length, True
                    break
        if not improved:
            break
    return order
