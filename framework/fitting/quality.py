"""How good a fit is, measured against the input trace: the criterion that decides whether a
plan edit is kept, and the threshold below which a finished fit is reported as poor.

The figures are the symmetric Chamfer distance between the input polylines and the fitted
trajectory (mean, px) and the Hausdorff distance (max, px), :func:`inkmotion.geometry.chamfer.
chamfer`, both directions, so a loop the fit leaves out counts as much as a stroke it adds.
The goals are given on a 350-px canvas (the authors' size) and scale with the canvas:

- the fit's criterion q = mean / (0.6 px·s) + max / (8 px·s), s = size / 350: each goal
  counts 1 when met exactly; lower is better. A plan edit is kept only when the refit from
  it has a q no higher than the fit before the edit (:mod:`inkmotion.fitting.stages`).
  From spec version 11 on the motion's time is weighed with them, by its own goal:
  q + r / 0.65, r the T_end ratio (T_end after / before the fit over the paths that began
  with 2 or more sub-movements), so a target that makes the motion slower must buy that
  time back in accuracy.
- a fit is *poor* when its max distance exceeds 8 px·s: some part of the input is drawn
  that far off, or not at all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkmotion.sigma_lognormal.plan import MotorPlan

#: px on a canvas of this longer side; the goals scale with the canvas
REFERENCE_SIZE = 350.0
#: px at the reference size: the goals of a fit, Chamfer mean and max
GOAL_MEAN_PX = 0.6
GOAL_MAX_PX = 8.0
#: the goal of the T_end ratio (T_end after / before the fit, paths of 2+ sub-movements)
GOAL_T_END_RATIO = 0.65


def chamfer_of(strokes: list[np.ndarray], plans: list[MotorPlan]) -> tuple[float, float]:
    """(mean, max) px between the input ``strokes`` and the fitted ``plans`` (on any device)."""
    from inkmotion.geometry.chamfer import chamfer
    from inkmotion.outputs.sampling import on_cpu, sample

    return chamfer(strokes, [sample(on_cpu(p)).positions for p in plans])


def criterion(mean: float, worst: float, size: float, t_end_ratio: float | None = None
              ) -> float:
    """q = mean / (0.6 px·s) + max / (8 px·s), s = size / 350, plus r / 0.65 where the T_end
    ratio r is given (module docstring)."""
    s = float(size) / REFERENCE_SIZE
    q = mean / (GOAL_MEAN_PX * s) + worst / (GOAL_MAX_PX * s)
    return q if t_end_ratio is None else q + t_end_ratio / GOAL_T_END_RATIO


def t_end_ratio(initial_moves: list[int], initial_t_end: list[float],
                final_t_end: list[float]) -> float:
    """T_end after / before the fit over the paths that began with 2 or more sub-movements
    (a single lognormal has no overlap to shorten): the sums of each path's T_end; NaN when
    no path did."""
    multi = [i for i, m in enumerate(initial_moves) if m >= 2]
    before = sum(initial_t_end[i] for i in multi)
    after = sum(final_t_end[i] for i in multi)
    return after / before if before > 0 else float("nan")


def poor_above(size: float) -> float:
    """The max Chamfer distance (px) above which a fit on a ``size``-px canvas is poor."""
    return GOAL_MAX_PX * float(size) / REFERENCE_SIZE


@dataclass(frozen=True)
class WorstMiss:
    """Where a fit misses its input most: the input stroke (0-based, in the input's order),
    the input point (x, y) there and its distance to the fitted motion (px)."""

    stroke: int
    point: tuple[float, float]
    distance: float


def worst_miss(strokes: list[np.ndarray], plans: list[MotorPlan]) -> WorstMiss:
    """The input point farthest from the fitted motion (the input → fit half of the Hausdorff
    distance, where a missing loop shows), or the fitted sample farthest from the input
    when that is farther (a stroke drawn where the input has none), named by the stroke
    nearest to it."""
    from scipy.spatial import cKDTree

    from inkmotion.geometry.chamfer import densify
    from inkmotion.outputs.sampling import on_cpu, sample

    dense = [densify(s) for s in strokes]
    stroke_of = np.concatenate([np.full(len(d), i) for i, d in enumerate(dense)])
    inputs = np.vstack(dense)
    fitted = np.vstack([densify(sample(on_cpu(p)).positions) for p in plans])
    d_in, _ = cKDTree(fitted).query(inputs)
    d_fit, near = cKDTree(inputs).query(fitted)
    if d_in.max() >= d_fit.max():
        k = int(np.argmax(d_in))
        return WorstMiss(int(stroke_of[k]), (float(inputs[k, 0]), float(inputs[k, 1])),
                    float(d_in[k]))
    k = int(np.argmax(d_fit))
    return WorstMiss(int(stroke_of[near[k]]), (float(fitted[k, 0]), float(fitted[k, 1])),
                float(d_fit[k]))
