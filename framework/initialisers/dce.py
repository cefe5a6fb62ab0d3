"""Discrete curve evolution of each stroke to its salient points: the plans the 'dce'
initialiser plugin starts a fit from.

Discrete curve evolution (Latecki & Lakämper 1998) repeatedly removes the vertex of a
polyline that contributes least to its shape, keeping the two endpoints. The relevance
of vertex v with neighbours u, w (the current, already simplified neighbours) is

    K(s1, s2) = β(s1, s2) · 2 · l1 · l2 / (l1 + l2)

with s1 = uv, s2 = vw, l1 = |s1|, l2 = |s2| in canvas px and β ∈ [0, π] the turning angle
at v in radians (0 on a straight continuation). This is Latecki & Lakämper's
β·l1·l2/(l1 + l2) times 2, i.e. turning angle × the harmonic mean of the two arm lengths,
so that for equal arms K = β·l. The order of removal is exactly DCE's; only the scale of
the stop criterion differs. K is in px·rad and *not* normalised by the stroke length (the
original divides by the perimeter; here a threshold means the same on every stroke of a
canvas). Removal stops when the smallest relevance exceeds the stop threshold. Read K as
"bend × local scale": for shallow turns K ≈ 2·h, h the distance of v from the chord uw,
so the default threshold 1.0 removes vertices that stand less than about 0.5 px off the
chord of their neighbours, whatever the arm lengths (a vertex between two 10-px arms is
kept when it turns by more than 0.1 rad ≈ 6°); a 90° corner is kept when its arms are
longer than about 0.65 px. Each removal updates only the two neighbours, so with a heap
(lazy deletion) the cost is O(n log n) per stroke.

Plan density, free of the canvas scale. The stop threshold is given by default as the
authors' relevance (their demo: turning angle in *degrees* × l1·l2/(l1 + l2), divided by
the canvas size, kept above 2.5), ``relevance`` = K·(180/π)/(2·size), i.e. the threshold
K* = relevance·2·size·π/180 px·rad (30.5 px·rad at 350 px for 2.5). Both K and size scale
with the canvas, so the same tag at 350 px and at 2000 px keeps the same vertices. The
default 2.5 is the authors': about one target per salient curvature extremum (29 targets
on 49867.json, 32 on 49873.json), the density at which the sub-movements are the strokes
a person makes. ``threshold`` (px·rad, absolute) overrides it; ``targets`` (the job's
``--targets N``) overrides both and searches the relevance that leaves about N
sub-movements over all strokes (bisection; DCE's removal order is fixed, so the count
falls monotonically with the threshold).

Initial turning angles. Between two kept vertices the trace is one sub-movement's path,
and its δ starts at the bend of a circular arc through the piece's ends (``estimate``):

- ``peak`` (the default): the arc through the trace's largest signed deviation h from
  the chord c, δ = 4·atan(2h/c) (sagitta h = (c/2)·tan(δ/4)). Right for a piece that is
  one arc, too round for a piece that runs straight and then turns (a diagonal into the
  top of an a's bowl): its arc bulges over the whole chord as far as the turn does, and
  a fit started from that arch may keep it (the picture of text:graffiti: 11.7 px from
  the recorded trace).
- ``fitted``: the arc closest to the whole piece, the least mean squared distance both
  ways between the arc and the piece (:func:`fitted_turn`); straighter where the piece
  bends only at one end.
- ``between``: halfway between the two (that picture: 7.5 px). Not the default: over
  the development set at 600 steps it left text:graffiti slower than the authors'
  (README, the picture benchmark).

Each is clamped to ±``max_bend`` (π, the half circle a fit's arc may turn; spec 16 and
before π/2, the authors' quarter circle, which started the sub-movements of a script
loop, such as an f's, at half their turn: the fit then spent its steps turning them and
cut the loops across). On a piece that is one arc all three agree. Starting from the
bend the trace has, rather than δ = 0 (straight chords), lets the optimiser spend its
steps on timing and overlap. ``bend = false`` starts every δ at 0 (the authors').

Each simplified stroke becomes one :class:`~inkmotion.MotorPlan` through its kept
vertices, with the initialisation defaults (Δt = 1, δ = 0, Ac = 0.01, T = 0.8). A third
coordinate (stroke radius, px) is carried along on the kept vertices; relevance uses
x, y only.
"""

from __future__ import annotations

import heapq
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from inkmotion.geometry.polyline import arc_length

if TYPE_CHECKING:
    from inkmotion.sigma_lognormal.plan import MotorPlan

#: the stop threshold in px·rad when one is given without a canvas (module docstring)
DEFAULT_THRESHOLD = 1.0
#: the default density: the authors' relevance, degrees × half harmonic mean length / size
DEFAULT_RELEVANCE = 2.5
#: the largest initial turning angle, radians: the half circle a fit's arc may turn
#: (its ``max_turn``, 180°)
MAX_BEND = math.pi
#: which arc an initial δ starts at (module docstring): peak, fitted or between
BEND_ESTIMATES = ("peak", "fitted", "between")
BEND_ESTIMATE = "peak"
#: :func:`fitted_turn`'s search: a grid over ±max_bend, then a finer one around its best
FIT_GRID, FIT_REFINE, ARC_SAMPLES = 121, 25, 33


def _relevance(u: np.ndarray, v: np.ndarray, w: np.ndarray) -> float:
    """K = β · 2 l1 l2 / (l1 + l2) at v between u and w (px·rad); 0 for a zero-length arm."""
    s1x, s1y = v[0] - u[0], v[1] - u[1]
    s2x, s2y = w[0] - v[0], w[1] - v[1]
    l1 = math.hypot(s1x, s1y)
    l2 = math.hypot(s2x, s2y)
    if l1 <= 1e-12 or l2 <= 1e-12:
        return 0.0
    beta = math.atan2(abs(s1x * s2y - s1y * s2x), s1x * s2x + s1y * s2y)  # turning angle
    return 2.0 * beta * l1 * l2 / (l1 + l2)


def dce_indices(points: np.ndarray, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
    """Indices (k,) of the vertices of ``points`` (n, ≥2) that survive DCE, in order.

    Endpoints are always kept. Vertices are removed in increasing order of relevance
    K = β·2·l1·l2/(l1 + l2) (px·rad, recomputed for the two neighbours after each removal)
    while the smallest relevance is ≤ ``threshold``.
    """
    p = np.asarray(points, dtype=np.float64)[:, :2]
    n = p.shape[0]
    if n <= 2:
        return np.arange(n)
    prev = np.arange(-1, n - 1)
    nxt = np.arange(1, n + 1)
    alive = np.ones(n, dtype=bool)
    version = np.zeros(n, dtype=np.int64)  # lazy deletion: heap entries carry a version

    # initial relevances, vectorised
    s1 = p[1:-1] - p[:-2]
    s2 = p[2:] - p[1:-1]
    l1 = np.hypot(s1[:, 0], s1[:, 1])
    l2 = np.hypot(s2[:, 0], s2[:, 1])
    cross = np.abs(s1[:, 0] * s2[:, 1] - s1[:, 1] * s2[:, 0])
    beta = np.arctan2(cross, np.einsum("ij,ij->i", s1, s2))
    denom = l1 + l2
    ok = (l1 > 1e-12) & (l2 > 1e-12)
    k0 = np.where(ok, 2.0 * beta * l1 * l2 / np.maximum(denom, 1e-300), 0.0)
    heap = [(float(k), i + 1, 0) for i, k in enumerate(k0)]
    heapq.heapify(heap)

    while heap:
        k, i, ver = heap[0]
        if k > threshold:
            break
        heapq.heappop(heap)
        if not alive[i] or ver != version[i]:
            continue  # stale entry
        alive[i] = False
        a, b = prev[i], nxt[i]
        nxt[a], prev[b] = b, a
        for j in (a, b):
            if 0 < j < n - 1:  # interior: endpoints are never candidates
                version[j] += 1
                heapq.heappush(
                    heap, (_relevance(p[prev[j]], p[j], p[nxt[j]]), j, int(version[j]))
                )
    return np.nonzero(alive)[0]


def dce(points: np.ndarray, threshold: float = DEFAULT_THRESHOLD) -> np.ndarray:
    """The salient points (k, D) of a polyline ``points`` (n, D) by discrete curve evolution.

    Relevance K = β·2·l1·l2/(l1 + l2) in px·rad on the first two columns; further columns
    (the radius) are kept on the surviving vertices. See :func:`dce_indices`.
    """
    p = np.asarray(points, dtype=np.float64)
    return p[dce_indices(p, threshold)]


def relevance_threshold(relevance: float, size: float) -> float:
    """The stop threshold K* (px·rad) of the authors' canvas-relative ``relevance`` on a
    canvas whose longer side is ``size`` px: K* = relevance·2·size·π/180."""
    return relevance * 2.0 * float(size) * math.pi / 180.0


def moves_at(strokes: list[np.ndarray], threshold: float) -> int:
    """Sub-movements over all ``strokes`` when DCE stops at ``threshold`` px·rad."""
    return sum(len(dce_indices(s, threshold)) - 1 for s in strokes)


def threshold_for_moves(strokes: list[np.ndarray], moves: int, size: float) -> float:
    """The stop threshold (px·rad) whose plans have the count of sub-movements nearest to
    ``moves`` over all ``strokes`` (bisection on the log threshold; the count falls
    monotonically as the threshold grows). Between 1 sub-movement per stroke and every
    input vertex."""
    lo, hi = 1e-6, 4.0 * math.pi * float(size)  # keeps everything / keeps only the ends
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        if moves_at(strokes, mid) > moves:
            lo = mid
        else:
            hi = mid
        if hi / lo < 1.0 + 1e-6:
            break
    return lo if abs(moves_at(strokes, lo) - moves) < abs(moves_at(strokes, hi) - moves) else hi


def initial_turns(points: np.ndarray, kept: np.ndarray, max_bend: float = MAX_BEND,
                  estimate: str = BEND_ESTIMATE) -> np.ndarray:
    """Turning angles δ (k − 1,) of the sub-movements between consecutive kept vertices
    ``kept`` (k,) of the polyline ``points`` (n, ≥2): the bend of the circular arc through
    each piece's ends that ``estimate`` names (module docstring: ``peak``, ``fitted`` or
    ``between``), clamped to ±``max_bend`` radians. The sign is the kinematics' (δ > 0
    bends to the right of the chord in canvas coordinates, y down, i.e.
    cross(chord, point − start) < 0)."""
    if estimate not in BEND_ESTIMATES:
        raise ValueError(f"estimate must be one of {BEND_ESTIMATES}, got {estimate!r}")
    p = np.asarray(points, dtype=np.float64)[:, :2]
    out = np.zeros(max(len(kept) - 1, 0))
    for i, (a, b) in enumerate(zip(kept[:-1], kept[1:], strict=True)):
        chord = p[b] - p[a]
        c = float(np.hypot(*chord))
        if b - a < 2 or c <= 1e-9:
            continue
        rel = p[a + 1:b] - p[a]
        h = (chord[0] * rel[:, 1] - chord[1] * rel[:, 0]) / c  # signed distance, (b − a − 1,)
        deviation = float(h[np.argmax(np.abs(h))])
        peak = -4.0 * math.atan(2.0 * deviation / c)
        if estimate == "peak":
            out[i] = peak
            continue
        fitted = fitted_turn(p[a:b + 1], max_bend)
        out[i] = fitted if estimate == "fitted" else 0.5 * (peak + fitted)
    return np.clip(out, -max_bend, max_bend)


def arc_points(chord: float, delta: np.ndarray, samples: int) -> np.ndarray:
    """Points (K, samples, 2) evenly along the circular arcs from (0, 0) to (``chord``, 0)
    that turn δ (K,), in the chord's frame: u along the chord, h = cross(chord, ·)/|chord|
    (δ > 0 bends to h < 0, :func:`initial_turns`'s sign). The heading runs from −δ/2 to
    δ/2 over the arc's length L = c·(δ/2)/sin(δ/2); δ = 0 is the chord itself."""
    t = np.linspace(0.0, 1.0, samples)[None, :]
    d = np.asarray(delta, dtype=np.float64)[:, None]
    straight = np.abs(d) < 1e-9
    safe = np.where(straight, 1.0, d)
    radius = chord / (2.0 * np.sin(safe / 2))  # L/δ
    u = np.where(straight, chord * t, radius * (np.sin(safe * (t - 0.5)) + np.sin(safe / 2)))
    h = np.where(straight, 0.0, -radius * (np.cos(safe * (t - 0.5)) - np.cos(safe / 2)))
    return np.stack(np.broadcast_arrays(u, h), -1)


def fitted_turn(piece: np.ndarray, max_bend: float = MAX_BEND, spacing: float = 1.0) -> float:
    """δ in [−max_bend, max_bend] of the circular arc through the ends of ``piece`` (n, 2)
    closest to it: the least sum of the mean squared distances from the piece (resampled
    every ``spacing`` px) to the arc and from the arc to the piece, searched on a grid of
    :data:`FIT_GRID` turns and then :data:`FIT_REFINE` around the best (a grid, so the
    answer is one of its values: a last-bit difference in the distances moves it only
    where two are tied)."""
    piece = np.asarray(piece, dtype=np.float64)[:, :2]
    chord = piece[-1] - piece[0]
    c = float(np.hypot(*chord))
    along = arc_length(piece)
    n = max(math.ceil(along[-1] / spacing) + 1, 3)
    at = np.linspace(0.0, along[-1], n)
    rel = np.column_stack((np.interp(at, along, piece[:, 0]),
                           np.interp(at, along, piece[:, 1]))) - piece[0]
    frame = np.column_stack((rel @ chord, chord[0] * rel[:, 1] - chord[1] * rel[:, 0])) / c

    def cost(turns: np.ndarray) -> np.ndarray:  # (K,)
        arcs = arc_points(c, turns, ARC_SAMPLES)  # (K, samples, 2)
        d2 = ((arcs[:, :, None, :] - frame[None, None, :, :]) ** 2).sum(-1)  # (K, s, n)
        return d2.min(2).mean(1) + d2.min(1).mean(1)

    grid = np.linspace(-max_bend, max_bend, FIT_GRID)
    best = float(grid[np.argmin(cost(grid))])
    step = float(grid[1] - grid[0])
    fine = np.clip(best + np.linspace(-step, step, FIT_REFINE), -max_bend, max_bend)
    return float(fine[np.argmin(cost(fine))])


def dce_plans(strokes: list[np.ndarray], size: float, *, targets: int | None = None,
              relevance: float = DEFAULT_RELEVANCE, threshold: float | None = None,
              bend: bool = True, max_bend: float = MAX_BEND,
              bend_estimate: str = BEND_ESTIMATE, width: float = 3.0,
              dtype: Any = None, device: Any = None) -> list[MotorPlan]:
    """One motor plan per stroke of ``strokes`` (each (n, ≥2) px) through its DCE salient
    points, on a canvas whose longer side is ``size`` px (module docstring).

    The stop threshold is, in order of precedence: the one leaving about ``targets``
    sub-movements over all strokes (:func:`threshold_for_moves`), the absolute
    ``threshold`` (px·rad), or the authors' canvas-relative ``relevance``
    (:func:`relevance_threshold`). ``bend`` starts each δ at the trace's bend
    (:func:`initial_turns`, the ``bend_estimate`` arc, at most ``max_bend`` radians), else
    at 0. Plans are float32
    unless ``dtype`` says otherwise.
    """
    import torch

    from inkmotion.sigma_lognormal.plan import MotorPlan

    if targets is not None:
        threshold = threshold_for_moves(strokes, targets, size)
    elif threshold is None:
        threshold = relevance_threshold(relevance, size)
    plans = []
    for stroke in strokes:
        kept = dce_indices(stroke, threshold)
        delta = initial_turns(stroke, kept, max_bend, bend_estimate) if bend \
            else np.zeros(len(kept) - 1)
        plan = MotorPlan.from_points(np.asarray(stroke, dtype=np.float64)[kept],
                                     width=width, dtype=dtype or torch.float32,
                                     device=device)
        plan.delta.copy_(torch.as_tensor(delta, dtype=plan.delta.dtype))
        plans.append(plan)
    return plans
