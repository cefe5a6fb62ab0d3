"""How long a machine takes for a plotter program: a model of GRBL's motion planner
(planner.c), written here because no maintained Python library estimates it (the
gcode-simulator package, which the tests use as an independent check, plans forward only).

Each motion block has its nominal speed (its feed, or the rapid rate for G0; both capped
along the block's direction by the per-axis rate, ``v·min_i 1/|u_i|`` with equal axes) and
its acceleration (the per-axis limit along its direction, the same way). A junction is
passed at most at min(v_j, nominal speeds) with GRBL's v_j (:func:`.timing.junction_speed`,
acceleration along the junction vector u2 − u1). A pen command or dwell empties the planner
(GRBL synchronises on M3/M5 and G4), so the machine stops there. Entry speeds come from a
backward pass (every block can still stop within the blocks the planner holds then:
``planner_blocks``) and a forward pass (reachable from the previous entry), and each block
is a trapezoid (or triangle) between its entry and exit speed.
"""

from __future__ import annotations

import math

import numpy as np

from inkmotion.plotter.machine import Machine
from inkmotion.plotter.program import Block
from inkmotion.plotter.timing import junction_speed


def _axis_limited(value: float, u: np.ndarray) -> np.ndarray:
    """The per-axis limit ``value`` along unit directions ``u`` (n, 2): value / max|u_i|."""
    return value / np.max(np.abs(u), axis=1)


def run_time(points: np.ndarray, feeds: np.ndarray, machine: Machine) -> float:
    """Seconds for the motion blocks from ``points[0]`` through ``points[1:]`` (n + 1, 2) mm
    at ``feeds`` (n,) mm/s (``inf``: rapid), from rest to rest."""
    d = np.diff(points, axis=0)
    length = np.linalg.norm(d, axis=1)
    moving = length > 1e-9
    d, length, feeds = d[moving], length[moving], np.asarray(feeds, dtype=float)[moving]
    n = len(length)
    if n == 0:
        return 0.0
    u = d / length[:, None]
    nominal = np.minimum(feeds, _axis_limited(machine.max_feed, u))
    accel = _axis_limited(machine.max_accel, u)
    entry_max = np.zeros(n)  # (entry speed)² limits, block 0 starts at rest
    if n > 1:
        jv = u[1:] - u[:-1]
        norm = np.linalg.norm(jv, axis=1)
        bent = norm > 1e-12
        unit = np.where(bent[:, None], jv / np.where(bent, norm, 1.0)[:, None], [1.0, 0.0])
        ja = _axis_limited(machine.max_accel, unit)
        vj = junction_speed(u[:-1], u[1:], ja, machine.junction_deviation)
        entry_max[1:] = np.minimum(vj, np.minimum(nominal[:-1], nominal[1:])) ** 2
    # backward: each block's exit can still stop within the blocks held after it
    window = max(1, machine.planner_blocks - 1)
    reach = np.concatenate([np.cumsum((2.0 * accel * length)[::-1])[::-1], [0.0]])
    entry = entry_max.copy()
    exit_sq = 0.0
    for i in range(n - 1, -1, -1):
        held = reach[i + 1] - reach[min(n, i + 1 + window)]  # 2·a·L of the blocks held
        exit_limit = min(exit_sq, held) if i < n - 1 else 0.0
        entry[i] = min(entry[i], exit_limit + 2.0 * accel[i] * length[i])
        exit_sq = entry[i]
    # forward: reachable from the previous entry
    for i in range(1, n):
        entry[i] = min(entry[i], entry[i - 1] + 2.0 * accel[i - 1] * length[i - 1])
    exit_ = np.append(entry[1:], 0.0)
    total = 0.0
    for i in range(n):
        total += _trapezoid(length[i], math.sqrt(entry[i]), math.sqrt(exit_[i]), nominal[i],
                            accel[i])
    return total


def _trapezoid(length: float, v0: float, v1: float, v_nominal: float, a: float) -> float:
    """Seconds to travel ``length`` from ``v0`` to ``v1``, at most ``v_nominal``, at ±a."""
    peak_sq = min(v_nominal**2, 0.5 * (v0**2 + v1**2) + a * length)
    peak = math.sqrt(max(peak_sq, max(v0, v1) ** 2))
    up = max(0.0, (peak**2 - v0**2) / (2.0 * a))
    down = max(0.0, (peak**2 - v1**2) / (2.0 * a))
    cruise = max(0.0, length - up - down)
    return (peak - v0) / a + (peak - v1) / a + cruise / peak


def estimate_time(blocks: list[Block], machine: Machine) -> dict[str, float]:
    """Seconds the machine takes for ``blocks`` from X0 Y0: ``total_s`` and its parts
    (``drawing_s``, ``travel_s``, ``pen_s`` for pen commands and dwells)."""
    parts = {"drawing_s": 0.0, "travel_s": 0.0, "pen_s": 0.0}
    here = np.zeros(2)
    run: list[tuple[np.ndarray, float, str]] = []

    def flush() -> None:
        nonlocal run
        if run:
            points = np.vstack([here_at_start] + [p for p, _, _ in run])
            feeds = np.array([f for _, f, _ in run])
            kinds = {k for _, _, k in run}
            key = "drawing_s" if kinds == {"draw"} else "travel_s"
            parts[key] += run_time(points, feeds, machine)
        run = []

    here_at_start = here
    for b in blocks:
        if b.kind in ("draw", "travel"):
            if not run:
                here_at_start = here
            xy = np.asarray(b.xy, dtype=float)
            run.append((xy[None], b.feed if b.kind == "draw" else math.inf, b.kind))
            here = xy
        else:
            flush()
            parts["pen_s"] += b.seconds if b.kind == "dwell" else machine.pen_move_s
    flush()
    return {"total_s": sum(parts.values()), **parts}
