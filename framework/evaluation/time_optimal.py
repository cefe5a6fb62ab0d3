"""The time-optimal timing of a path under speed and acceleration limits (paper, section
"Evaluation": TOTG, Kunz & Stilman 2013, "Time-optimal trajectory generation for path
following with bounded acceleration and velocity").

Stand-in. We solve the same problem — the fastest rest-to-rest parametrisation s(t) of a
fixed geometric path under velocity and acceleration limits — with TOPP-RA (Pham & Pham
2018, "A new approach to time-optimal path parameterization based on reachability
analysis", the maintained ``toppra`` library) instead of TOTG, which has no maintained
Python package. Both give the bang-bang / on-the-limit solution (triangular and
trapezoidal speed segments, discontinuous acceleration); TOPP-RA discretises the path at
grid points where TOTG integrates the phase plane exactly, so the optimum is met on the grid.

Path. A cubic spline (``toppra.SplineInterpolator``) through via points of the given path
(:func:`inkmotion.evaluation.timings.via_points`, ``SPACING`` px / ``MAX_TURN``) over their
normalised chord length s ∈ [0, 1].

Limits on the norms, |v| ≤ v_max and |a| ≤ a_max (not toppra's per-axis boxes, which would
be either optimistic (box v_max: up to √2 v_max along a diagonal) or conservative (v_max/√2
per axis)). With x = ṡ², u = s̈, v = q'(s) ṡ and a = q'(s) u + q''(s) x:

- speed: exact, x ≤ v_max² / |q'(s)|² (a bound on x, :class:`SpeedNormConstraint`);
- acceleration: the disc |a| ≤ a_max approximated by its inscribed regular polygon of
  ``DIRECTIONS`` sides, e_k·a ≤ a_max cos(π/K) (linear in (u, x),
  :class:`AccelerationPolygonConstraint`): never above a_max, at most 1 − cos(π/K) (0.5 %
  for K = 32) below it along a vertex.

Then ``compute_trajectory(0, 0)`` (rest to rest). The limits hold at the grid points
(``GRID_PER_INTERVAL`` per via point interval); between them a tight bend can exceed them
by a little (< 0.5 % on the fitted tags), so the solution's peaks are measured at
``PEAK_RATE`` and, where one exceeds a limit, the timing is slowed uniformly by that factor
(:func:`inkmotion.robot.timing.time_scale`). It is then stretched to a whole number of
control periods (≤ 1/rate) and sampled at ``rate``; the jerk is the finite difference of the
sampled acceleration (it is a train of impulses where the acceleration jumps).
"""

from __future__ import annotations

import math

import numpy as np
import toppra
import toppra.algorithm
from toppra.constraint import DiscretizationType, LinearConstraint
from toppra.constraint.linear_constraint import canlinear_colloc_to_interpolate

from inkmotion.evaluation.timings import TimedPath, control_samples, peaks, via_points
from inkmotion.robot.timing import time_scale

#: via points of the geometric path: at most this far apart (path units, px) ...
SPACING = 2.0
#: ... and at most this much turning apart (rad)
MAX_TURN = math.radians(3.0)
#: sides of the polygon inscribed in the acceleration disc
DIRECTIONS = 32
#: samples per second on which the solution's peaks are checked
PEAK_RATE = 20_000.0
#: TOPP-RA grid points per via point interval
GRID_PER_INTERVAL = 8


class SpeedNormConstraint(LinearConstraint):
    """|q'(s) ṡ| ≤ v_max, exactly: x = ṡ² ≤ v_max² / |q'(s)|² at each grid point."""

    def __init__(self, v_max: float, dof: int = 2) -> None:
        super().__init__()
        self.v_max = float(v_max)
        self.dof = dof

    def compute_constraint_params(self, path, gridpoints, *args, **kwargs):  # noqa: ANN001, ANN201
        speed2 = np.sum(path(gridpoints, 1) ** 2, axis=1)
        xbound = np.column_stack((np.zeros(len(gridpoints)),
                                  self.v_max**2 / np.maximum(speed2, 1e-300)))
        return None, None, None, None, None, None, xbound


class AccelerationPolygonConstraint(LinearConstraint):
    """e_k·(q'(s) u + q''(s) x) ≤ a_max cos(π/K) for the K unit directions e_k: the
    acceleration within the regular K-gon inscribed in the disc of radius a_max
    (interpolation discretisation: also enforced at the next grid point's state)."""

    def __init__(self, a_max: float, directions: int = DIRECTIONS) -> None:
        super().__init__()
        angle = 2.0 * np.pi * np.arange(directions) / directions
        self.normals = np.column_stack((np.cos(angle), np.sin(angle)))  # (K, 2)
        self.bound = float(a_max) * math.cos(math.pi / directions)
        self.dof = 2
        self.identical = True
        self.set_discretization_type(DiscretizationType.Interpolation)

    def compute_constraint_params(self, path, gridpoints, *args, **kwargs):  # noqa: ANN001, ANN201
        ps, pss = path(gridpoints, 1), path(gridpoints, 2)  # (N, 2) each
        g = np.full(len(self.normals), self.bound)
        return canlinear_colloc_to_interpolate(ps, pss, np.zeros_like(ps), self.normals, g,
                                               None, None, gridpoints, identical=True)


def time_optimal_timing(path: np.ndarray, v_max: float, a_max: float, rate: float = 1000.0,
                        *, spacing: float = SPACING, max_turn: float = MAX_TURN
                        ) -> TimedPath:
    """The time-optimal rest-to-rest timing of the polyline ``path`` (N, 2+) with
    |v| ≤ v_max and |a| ≤ a_max (see the module docstring), sampled at ``rate``."""
    points = via_points(path, spacing, max_turn)
    chord = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate(([0.0], np.cumsum(chord))) / chord.sum()
    geometric = toppra.SplineInterpolator(s, points, bc_type="natural")
    grid = np.interp(np.arange(GRID_PER_INTERVAL * (len(s) - 1) + 1) / GRID_PER_INTERVAL,
                     np.arange(len(s)), s)
    constraints = [SpeedNormConstraint(v_max), AccelerationPolygonConstraint(a_max)]
    solver = toppra.algorithm.TOPPRA(constraints, geometric, gridpoints=grid,
                                     parametrizer="ParametrizeConstAccel")
    trajectory = solver.compute_trajectory(0.0, 0.0)
    if trajectory is None:
        raise AssertionError("TOPP-RA found no feasible parametrisation")  # pragma: no cover
    optimal = float(trajectory.duration)
    tau = np.linspace(0.0, optimal, max(2, math.ceil(PEAK_RATE * optimal)))
    speed, acc = peaks(trajectory(tau, 1), trajectory(tau, 2))
    k = max(1.0, time_scale(speed, acc, v_max, a_max)[0])  # between grid points
    t, stretch = control_samples(k * optimal, rate)
    stretch *= k
    tau = np.minimum(t / stretch, optimal)
    x = trajectory(tau)
    v = trajectory(tau, 1) / stretch
    a = trajectory(tau, 2) / stretch**2
    jerk = np.gradient(a, 1.0 / rate, axis=0)
    info = {"optimal_duration": optimal, "time_scale": stretch, "via_points": len(points),
            "grid_points": len(grid), "solver": "TOPP-RA (toppra), standing in for TOTG"}
    return TimedPath(t, x, v, a, jerk, "time-optimal", info)
