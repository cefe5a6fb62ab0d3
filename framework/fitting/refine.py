"""Editing a fitted motor plan between fit stages: a virtual target inserted where the fit
misses the input most, two sub-movements merged where the fit made them one.

A ΣΛ motor plan is sparse by design: about one virtual target
per salient stroke. DCE places the targets from the geometry alone; after a first fit
stage the residual says where the plan lacks a stroke (a sharp hook that the overlapping
lognormals cut short), and the overlaps say where it has one too many (Δt_i pinned at its
0.1 floor: sub-movement i starts while i − 1 has barely begun, so the two act as one).
Between stages the plan is edited, and the next stage continues from the edited plan,
which keeps every other parameter as fitted.

Residual. The input strokes and the fitted trajectories are densified
(:func:`inkmotion.geometry.chamfer.densify`); each input point's residual is its distance
to the nearest fitted sample, d(a, B) of the Chamfer distance. Candidates are taken
greedily: the worst input point, then the worst one more than ``separation`` px away from
every point taken so far, while the residual exceeds ``above`` px. The other way round, a
fitted sample farther than ``astray`` px (the goal's max distance) from every input point
is a shortcut drawn across bare paper while other passes cover the ink it skipped (the
input's residual does not see it); it is a candidate too, ranked by that distance: the
input point nearest to it, to be passed at the sample's own time on its path.

Insertion. For a candidate q the fit should pass q at a time t* on path p: half-way
between the times at which it passes the nearest well-fitted input points before and
after q on the same stroke (a hook that the overlapping strokes cut off is bracketed by
where the fit is still on the trace; the nearest fitted sample to q itself often lies on
another part of the path), else at the nearest fitted sample. The sub-movement i that moves
the pen most at t*, argmax_i Λ_i(t*)·|d_i| (the lognormal
speed profile of eq. "velocity" times its amplitude), is split at q: targets
…, p_{i−1}, q, p_i, … with δ_i halved on both halves and Ac, T of sub-movement i copied
to both; under 'hand' sparsity the two halves share most of the time of the one they
replace (each overlaps by ¾·Δt_i: a correction costs the motion half the time a whole new
stroke would), except where the miss is beyond the goal's max distance (such an excursion
needs time of its own to be reached), and under spec version 4's 'budget' rule both copy
Δt_i.

Merging. Where Δt_i (i ≥ 2) is within 1e-6 of the floor, target p_{i−1}, where
sub-movement i − 1 ends and i begins, is removed: sub-movement i − 1 then runs from
p_{i−2} to p_i with δ_{i−1} + δ_i (the two arcs' turns add) and its own Δt, Ac and T.
One merge per pair per edit; the next stage refits the merged plan. (Keeping only the
merges that move the trajectory by at most 2 or 6 px before the refit kept nearly none,
and left the pins: temptTag-2010_7_28's one overlap stayed at the floor; merging them all
costs 49867.json's max Chamfer 2.6 → 5.2 px and leaves no Δt at a bound on any real tag.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from scipy.spatial import cKDTree

from inkmotion.geometry.chamfer import densify
from inkmotion.geometry.polyline import arc_length
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.params import DELTA_RANGE, DELTA_T_RANGE, delta_range
from inkmotion.sigma_lognormal.plan import MotorPlan

#: |Δt − floor| below which an overlap counts as pinned at the floor
FLOOR_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Miss:
    """One place where the fit misses the input: the input point q (2,), its distance to
    the fit (px), the fitted path p and the time t* of its nearest sample there."""

    point: np.ndarray
    distance: float
    path: int
    time: float


@dataclass(frozen=True)
class FittedSamples:
    """Dense samples of fitted plans: positions (N, 2), their path (N,) and time (N,)."""

    positions: np.ndarray
    path: np.ndarray
    time: np.ndarray

    @classmethod
    def of(cls, plans: list[MotorPlan], per_move: int = 20,
           spacing: float = 0.25) -> FittedSamples:
        """Each plan sampled uniformly in time (``per_move`` per sub-movement), then
        densified to ``spacing`` px along the polyline (as the Chamfer distance measures
        it), times interpolated along it."""
        from inkmotion.outputs.sampling import sample

        positions, paths, times = [], [], []
        for i, plan in enumerate(plans):
            s = sample(plan, per_move)
            xy = s.positions[:, :2]
            dense = densify(xy, spacing)
            arc, dense_arc = arc_length(xy), arc_length(dense)
            positions.append(dense)
            paths.append(np.full(len(dense), i))
            times.append(np.interp(dense_arc, arc, s.t))
        return cls(np.vstack(positions), np.concatenate(paths), np.concatenate(times))


def worst_misses(strokes: list[np.ndarray], plans: list[MotorPlan], *, above: float,
                 separation: float, limit: int, astray: float = math.inf) -> list[Miss]:
    """At most ``limit`` input points farther than ``above`` px from the fit, worst first,
    each more than ``separation`` px from those before it (module docstring); and, among
    them by distance, the fit's own samples farther than ``astray`` px from the input (a
    shortcut drawn across bare paper while other passes cover the ink it skipped), each a
    miss at the input point nearest to it, at the sample's path and time."""
    if limit <= 0:
        return []
    fitted = FittedSamples.of(plans)
    tree = cKDTree(fitted.positions)
    dense = [densify(s) for s in strokes if len(s)]
    stroke_of = np.concatenate([np.full(len(d), i) for i, d in enumerate(dense)])
    points = np.vstack(dense)  # (K, 2)
    distance, nearest = tree.query(points)
    candidates = [(float(distance[k]), int(k), -1) for k in np.flatnonzero(distance > above)]
    if math.isfinite(astray):
        away, ink = cKDTree(points).query(fitted.positions)
        candidates += [(float(away[j]), int(ink[j]), int(j))
                       for j in np.flatnonzero(away > astray)]
    taken: list[Miss] = []
    for d, k, j in sorted(candidates, key=lambda c: (-c[0], c[1], c[2])):
        if len(taken) >= limit:
            break
        q = points[k]
        if any(np.hypot(*(q - t.point)) <= separation for t in taken):
            continue
        if j < 0:
            path, time = _passage(k, stroke_of, distance, nearest, fitted, above)
        else:
            path, time = int(fitted.path[j]), float(fitted.time[j])
        taken.append(Miss(q, d, path, time))
    return taken


def _passage(k: int, stroke_of: np.ndarray, distance: np.ndarray, nearest: np.ndarray,
             fitted: FittedSamples, above: float) -> tuple[int, float]:
    """The fitted path and time at which the fit should pass the missed input point ``k``:
    between the times of the nearest well-fitted input points (residual ≤ ``above``) of
    the same stroke before and after it, when both lie on one path (a missed excursion —
    a hook the overlapping strokes cut off — is bracketed by where the fit is still on
    the trace); else the time of the nearest fitted sample."""
    same = np.flatnonzero(stroke_of == stroke_of[k])
    good = same[distance[same] <= above]
    before, after = good[good < k], good[good > k]
    if len(before) and len(after):
        a, b = nearest[before[-1]], nearest[after[0]]
        if fitted.path[a] == fitted.path[b]:
            return int(fitted.path[a]), 0.5 * float(fitted.time[a] + fitted.time[b])
    j = nearest[k]
    return int(fitted.path[j]), float(fitted.time[j])


def dominant_move(plan: MotorPlan, t: float) -> int:
    """The sub-movement i (0-based) that moves the pen most at time ``t``:
    argmax_i Λ_i(t)·|d_i| (module docstring)."""
    p = plan.detached().to(device="cpu", dtype=torch.float64)
    sigma, mu, t0 = (x.numpy() for x in PlanBatch.from_plans([p]).timing())
    tau = np.maximum(t - t0, 1e-12)
    density = np.exp(-((np.log(tau) - mu) ** 2) / (2 * sigma**2)) / (sigma * tau)
    density = np.where(t > t0, density, 0.0)
    amplitude = np.linalg.norm(np.diff(p.points.numpy()[:, :2], axis=0), axis=1)
    return int(np.argmax(density * amplitude))


def _rebuild(plan: MotorPlan, points: torch.Tensor, delta_t: torch.Tensor,
             delta: torch.Tensor, ac: torch.Tensor, T: torch.Tensor) -> MotorPlan:
    return MotorPlan(points, delta_t, delta, ac, T, plan.width)


#: ``keep_time`` splits: each half overlaps by this share of the Δt it replaces, so T_end
#: grows by half the replaced overlap instead of all of it (½: no growth, measured on the
#: development set: the halves then ran together and cut the hook they were to reach)
SPLIT_SHARE = 0.75


def split_move(plan: MotorPlan, i: int, q: np.ndarray, keep_time: bool = False) -> MotorPlan:
    """``plan`` with sub-movement ``i`` (0-based) split at the new target ``q`` (2,); a 3-D
    plan's new target takes the radius half-way between its neighbours.

    ``keep_time``: the two halves share most of the time of the sub-movement they
    replace, each with :data:`SPLIT_SHARE` of its overlap Δt_i (at least the floor), so
    every later onset, and T_end, move by (2·SPLIT_SHARE − 1)·Δt_i·T_i instead of
    Δt_i·T_i; the first sub-movement, whose Δt is unused, hands its second half an
    overlap of SPLIT_SHARE. Otherwise both halves copy Δt_i (spec version 4)."""
    p = plan.detached()
    new = torch.as_tensor(np.asarray(q, dtype=np.float64)[:2], dtype=p.points.dtype,
                          device=p.points.device)
    if p.dim == 3:
        new = torch.cat((new, 0.5 * (p.points[i, 2:] + p.points[i + 1, 2:])))
    points = torch.cat((p.points[:i + 1], new[None], p.points[i + 1:]))
    twice = lambda x: torch.cat((x[:i + 1], x[i:]))  # noqa: E731  (m,) -> (m + 1,)
    delta = twice(p.delta)
    delta[i:i + 2] = p.delta[i] / 2
    delta_t = twice(p.delta_t)
    if keep_time:
        floor = DELTA_T_RANGE[0]
        if i == 0:
            delta_t[1] = SPLIT_SHARE
        else:
            delta_t[i:i + 2] = (p.delta_t[i] * SPLIT_SHARE).clamp_min(floor)
    return _rebuild(p, points, delta_t, delta, twice(p.ac), twice(p.T))


def merge_move(plan: MotorPlan, i: int, delta_limit: float = DELTA_RANGE[1]) -> MotorPlan:
    """``plan`` with sub-movement ``i`` (0-based, ≥ 1) merged into i − 1: the target p_i
    between them removed, δ_{i−1} + δ_i (clamped to ±``delta_limit``, the fit's own clamp)
    on the merged one (module docstring)."""
    p = plan.detached()
    keep_moves = [j for j in range(p.m) if j != i]
    keep_points = [j for j in range(p.m + 1) if j != i]  # point i joins i − 1 and i
    delta = p.delta.clone()
    delta[i - 1] = delta[i - 1] + delta[i]
    delta = delta.clamp(*delta_range(delta_limit))
    idx = torch.as_tensor(keep_moves, device=p.points.device)
    return _rebuild(p, p.points[torch.as_tensor(keep_points, device=p.points.device)],
                    p.delta_t[idx], delta[idx], p.ac[idx], p.T[idx])


#: degrees: an input that turns by at least this much within :data:`SALIENT_ARM` px of a
#: target makes it a salient corner (or a hook), whose sub-movement a merge never removes
SALIENT_TURN_DEG = 60.0
#: px at a 350-px canvas (scaled with it): the arms over which the input's turn is measured
SALIENT_ARM = 8.0


def _at(xy: np.ndarray, arc: np.ndarray, s: float) -> np.ndarray:
    """The point (2,) at arc length ``s`` along the polyline ``xy`` (clipped to its ends)."""
    return np.array([np.interp(s, arc, xy[:, 0]), np.interp(s, arc, xy[:, 1])])


def input_turn(strokes: list[np.ndarray], q: np.ndarray, arm: float) -> float:
    """Degrees the input turns at its point nearest to ``q`` (2,): the angle between the
    chords from ``arm`` px of arc before that point to it and from it to ``arm`` px after
    (clipped at the stroke's ends; 0 at an end)."""
    best, turn = np.inf, 0.0
    for stroke in strokes:
        xy = np.asarray(stroke, dtype=np.float64)[:, :2]
        if len(xy) < 3:
            continue
        arc = arc_length(xy)
        k = int(np.argmin(np.hypot(*(xy - q[:2]).T)))
        d = float(np.hypot(*(xy[k] - q[:2])))
        if d >= best:
            continue
        best = d
        a, b, c = _at(xy, arc, arc[k] - arm), xy[k], _at(xy, arc, arc[k] + arm)
        u, v = b - a, c - b
        if np.hypot(*u) < 1e-9 or np.hypot(*v) < 1e-9:
            turn = 0.0
            continue
        turn = math.degrees(math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v)))
    return turn


def salient_targets(plan: MotorPlan, strokes: list[np.ndarray], size: float) -> set[int]:
    """Indices of the interior targets of ``plan`` at which the input turns by at least
    :data:`SALIENT_TURN_DEG` (a sharp corner or a hook): a merge keeps them."""
    points = plan.points.detach().cpu().numpy()
    arm = SALIENT_ARM * float(size) / 350.0
    return {j for j in range(1, plan.m)
            if input_turn(strokes, points[j, :2], arm) >= SALIENT_TURN_DEG}


def merge_pinned(plan: MotorPlan, keep: set[int] | None = None,
                 limit: int | None = None, delta_limit: float = DELTA_RANGE[1]
                 ) -> tuple[MotorPlan, int]:
    """``plan`` with the pairs of sub-movements whose second Δt sits at the floor merged
    into one (module docstring), and how many were merged (at most ``limit``); pairs are
    taken from the last to the first, so a merged pair is not merged again in the same
    edit. Targets whose index is in ``keep`` (salient corners, :func:`salient_targets`)
    are never removed; ``delta_limit``: :func:`merge_move`'s."""
    p = plan.detached()
    floor = DELTA_T_RANGE[0]
    pinned = ((p.delta_t - floor).abs() <= FLOOR_TOLERANCE).tolist()
    for j in keep or ():
        pinned[j] = False  # merging sub-movement j into j − 1 removes target p_j
    merged = 0
    for i in range(p.m - 1, 0, -1):  # Δt_1 (index 0) is unused
        if limit is not None and merged >= limit:
            break
        if pinned[i]:
            p, merged = merge_move(p, i, delta_limit), merged + 1
            pinned[i - 1] = False  # one merge per pair: i − 1 now holds both
    return p, merged


def insert_targets(plans: list[MotorPlan], misses: list[Miss],
                   keep_time: bool = False, sequential_above: float = math.inf
                   ) -> list[MotorPlan]:
    """``plans`` with one target inserted per miss (module docstring), latest time first
    within a path so earlier indices stay valid; ``keep_time``: see :func:`split_move`,
    except for misses farther than ``sequential_above`` px (an excursion that big needs
    time of its own to be reached)."""
    out = list(plans)
    for miss in sorted(misses, key=lambda m: (m.path, -m.time)):
        i = dominant_move(out[miss.path], miss.time)
        out[miss.path] = split_move(out[miss.path], i, miss.point,
                                    keep_time and miss.distance <= sequential_above)
    return out


#: a plan grows by at most this share of its sub-movements in one budget (a plan stays
#: sparse: about one target per salient stroke, so within 25 % of the authors' density)
MAX_GROWTH = 0.25
#: merges leave at least this share of a plan's initial sub-movements
MIN_KEPT = 0.75


#: sub-movements a very small plan may gain beyond :data:`MAX_GROWTH` (a 5-move tag with a
#: hook the DCE missed needs one more, which 25 % of 5 does not give)
SMALL_PLAN_EXTRA = 2
#: "very small": fewer initial sub-movements than this (under a rule whose
#: ``extra_small_only``; spec version 4's 'budget' gave the extra to every plan)
SMALL_PLAN_BELOW = 8


@dataclass(frozen=True)
class Sparsity:
    """How sparse the default mode keeps a plan (the fit's ``--sparsity``): every way the
    rules differ, in one place.

    A target is inserted only where the input is farther than ``insert_above`` px from the
    fit (px on a 350-px canvas, scaled with it when ``scaled``), and an edit that inserts k
    targets is kept only if it lowers the criterion (:func:`inkmotion.fitting.quality.
    criterion`, goal-normalised) by at least ``gain_per_target`` × k + ``margin``. The
    margin is the decision's distance from round-off: a gain that clears the bar by less
    than it is not taken, so last-bit differences of another machine's arithmetic
    (which a refit carries into the criterion's last digits) do not flip the decision."""

    insert_above: float
    gain_per_target: float
    margin: float
    scaled: bool
    #: an edit that brings a fit's worst miss from above the goal's max distance to at
    #: least this share below it is kept whatever it gained per target (0: never)
    rescue_margin: float = 0.0
    #: split halves share the replaced sub-movement's time (:func:`split_move`)
    shared_time: bool = False
    #: the growth margin's +2 only for plans below :data:`SMALL_PLAN_BELOW` (else every plan)
    extra_small_only: bool = False
    #: merges leave at least this share of the initial sub-movements (0: no floor)
    min_kept: float = 0.0
    #: a rolled-back insertion of shared-time splits is tried once more with sequential ones
    retry_sequential: bool = False


#: 'hand': a target only for a miss a person would see — 3 px, the width of the pen, on a
#: 350-px canvas — and only if it buys 0.1 of the criterion (0.06 px of mean or 0.8 px of
#: max distance) or turns a poor fit (worst miss above 8 px) into a good one (below
#: 7.76 px), the plan within 1.25× its initial size (+2 below 8) and 0.75× after merges;
#: 'budget': spec version 4's rule (misses above 2 px, 0.05 per target, no margin, 25 % + 2
#: for every plan), which spent its whole budget on most inputs
SPARSITY = {"hand": Sparsity(3.0, 0.1, 0.02, True, rescue_margin=0.03, shared_time=True,
                             extra_small_only=True, min_kept=MIN_KEPT,
                             retry_sequential=True),
            "budget": Sparsity(2.0, 0.05, 0.0, False)}


def growth_margin(moves: int, rule: Sparsity | str = "hand") -> int:
    """The targets all edits of a fit together may add to a plan of ``moves`` sub-movements
    under ``rule`` (a :class:`Sparsity` or its name): :data:`MAX_GROWTH` of them (rounded
    down), plus :data:`SMALL_PLAN_EXTRA` for a plan of fewer than :data:`SMALL_PLAN_BELOW`
    ('hand') or for every plan ('budget'): the fit's density goal, m within 1.25× the
    authors' count, +2 only where that count is below 8."""
    rule = SPARSITY[rule] if isinstance(rule, str) else rule
    small = moves < SMALL_PLAN_BELOW or not rule.extra_small_only
    return math.floor(MAX_GROWTH * moves) + (SMALL_PLAN_EXTRA if small else 0)


def fewest_moves(moves: int, share: float = MIN_KEPT) -> int:
    """The fewest sub-movements merges may leave of a plan of ``moves``: ⌈share·moves⌉
    (0 for no floor)."""
    return math.ceil(share * moves - 1e-9)


def budget(moves: int, fraction: float) -> int:
    """Targets an edit may add to a plan of ``moves`` sub-movements: ``fraction`` of them,
    rounded, and never more than :data:`MAX_GROWTH` of them (rounded down)."""
    return max(0, min(math.floor(fraction * moves + 0.5), math.floor(MAX_GROWTH * moves)))
