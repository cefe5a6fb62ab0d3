"""Path-constrained minimum jerk (Todorov & Jordan 1998, "Smoothness maximization along a
predefined path accurately predicts the speed profiles of complex arm movements"), resampled
to the same limits as the other timings (paper, section "Evaluation").

Formulation (theirs). The path is given by via points p_0..p_{M−1}; the trajectory minimises
the integrated squared jerk J = ∫_0^T |x⃛(t)|² dt among all trajectories that start and end
at rest (v = a = 0) and pass through the via points in order, over the passage times too.

Inner problem (fixed passage times, durations h_k). The minimiser is a quintic spline, C⁴
at the via points (Euler–Lagrange: x⁽⁶⁾ = 0 between them). We write each piece as the quintic
Hermite interpolant of its end values (p, v, a); its cost is closed-form,

    J_k = h_k⁻⁵ z_kᵀ K z_k,   z_k = (p_k, h_k v_k, h_k² a_k, p_{k+1}, h_k v_{k+1}, h_k² a_{k+1}),

with K the 6×6 jerk Gram matrix of the unit-interval Hermite basis. Minimising Σ J_k over
the interior velocities and accelerations (C² by construction; C³, C⁴ follow at the
optimum) is an unconstrained quadratic: one sparse, banded SPD solve (both coordinates at
once). This equals the equality-constrained QP in the spline coefficients, without OSQP.

Outer problem (passage times). With the total duration fixed to 1 (J scales as T⁻⁵, and the
time scaling below sets the real duration), h = softmax(θ); log J(h) is minimised by
L-BFGS with the exact gradient from the envelope theorem, ∂J/∂h_k = ∂J_k/∂h_k at the inner
optimum. J(h) is not convex, so this is a local optimum: it is solved coarse to fine
(:func:`coarse_to_fine`), the coarsest level started from h_k ∝ chord length, each finer
one from the previous level's timing law.

Deviations. The via points are taken from the given (ΣΛ) path by
:func:`inkmotion.evaluation.timings.via_points`: dense (``SPACING`` px, ``MAX_TURN`` of
turning; ~200 points for a 670 px path of a fitted tag), so the spline follows the path
within ~0.01 px between them; between via points it is the spline's own curve, not the
given one. The result is then
uniformly time-scaled to v_max and a_max and resampled at the control rate, as the paper
does (minimum jerk itself has no limits).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
import scipy.optimize
from scipy.interpolate import PchipInterpolator

from inkmotion.evaluation.timings import (
    SAFETY,
    TimedPath,
    control_samples,
    peaks,
    via_points,
    via_points_and_times,
)
from inkmotion.robot.timing import time_scale

#: via points at most this far apart along the path (path units, px)
SPACING = 8.0
#: ... and at most this much turning apart (rad)
MAX_TURN = math.radians(6.0)
#: the coarsest level of :func:`coarse_to_fine` has at most this many via points
COARSEST = 24
#: L-BFGS: at most this many iterations per level, stopping at this relative decrease of
#: log J per iteration
MAX_ITER = 3000
FTOL = 1e-9
#: samples per piece on which the peaks of the unit-duration spline are measured
PEAK_SAMPLES = 48


def _hermite_basis() -> np.ndarray:
    """(6, 6) B with c = B z: monomial coefficients c_0..c_5 of the quintic on τ ∈ [0, 1]
    whose value, first and second derivative are z = (x0, x0', x0'', x1, x1', x1'')."""
    rows = []
    for tau in (0.0, 1.0):
        for order in range(3):
            row = [0.0] * 6
            for j in range(order, 6):
                row[j] = math.perm(j, order) * tau ** (j - order)
            rows.append(row)
    return np.linalg.inv(np.array(rows))


#: (6, 6) monomial coefficients of the unit quintic Hermite basis
BASIS = _hermite_basis()
#: (6, 6) K = Bᵀ G B, G_ij = ∫_0^1 (τ^i)‴ (τ^j)‴ dτ: ∫_0^1 |x‴(τ)|² dτ = zᵀ K z
_G = np.zeros((6, 6))
for _i in range(3, 6):
    for _j in range(3, 6):
        _G[_i, _j] = math.perm(_i, 3) * math.perm(_j, 3) / (_i + _j - 5)
JERK_GRAM = BASIS.T @ _G @ BASIS


def _scales(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """D(h) = diag(1, h, h², 1, h, h²) per piece and its derivative dD/dh, (M−1, 6) each."""
    one, zero = np.ones_like(h), np.zeros_like(h)
    d = np.stack([one, h, h**2, one, h, h**2], axis=1)
    dd = np.stack([zero, one, 2 * h, zero, one, 2 * h], axis=1)
    return d, dd


class _Spline:
    """The minimum-jerk quintic spline through via points (M, 2) for given durations.

    Unknowns: (v_i, a_i) of the interior knots i = 1..M−2, ordered knot by knot, so the
    normal matrix is SPD and banded (bandwidth 3): one ``solveh_banded`` per evaluation."""

    def __init__(self, points: np.ndarray) -> None:
        m = len(points)
        self.m = m
        # knot k carries variables (p, v, a) at 3k, 3k+1, 3k+2; piece k uses knots k, k+1
        self.index = 3 * np.arange(m - 1)[:, None] + np.arange(6)[None, :]  # (M−1, 6)
        self.values = np.zeros((3 * m, 2))
        self.values[0::3] = points
        # free unknowns of piece k: local 1, 2 (knot k) and 4, 5 (knot k + 1)
        local = np.array([1, 2, 4, 5])
        k = np.arange(m - 1)[:, None]
        knot = k + np.array([0, 0, 1, 1])[None, :]
        glob = 2 * (knot - 1) + np.array([0, 1, 0, 1])[None, :]  # (M−1, 4)
        valid = (knot >= 1) & (knot <= m - 2)
        ia, ib = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
        pair = valid[:, :, None] & valid[:, None, :] & (glob[:, :, None] <= glob[:, None, :])
        self.pair = pair  # (M−1, 4, 4)
        self.band_rows = (3 + glob[:, :, None] - glob[:, None, :])[pair]
        self.band_cols = np.broadcast_to(glob[:, None, :], pair.shape)[pair]
        self.local_a = local[ia]
        self.local_b = local[ib]
        self.rhs_valid = valid
        self.rhs_index = glob
        self.local = local
        self.n_free = 2 * max(m - 2, 0)

    def solve(self, h: np.ndarray) -> tuple[float, np.ndarray]:
        """J(h) and the knot values (3M, 2) (p, v, a per knot) of the optimal spline."""
        d, _ = _scales(h)
        s = h[:, None, None] ** -5 * d[:, :, None] * JERK_GRAM[None] * d[:, None, :]
        values = self.values.copy()
        if self.n_free:
            band = np.zeros((4, self.n_free))
            block = s[:, self.local_a, self.local_b]  # (M−1, 4, 4)
            np.add.at(band, (self.band_rows, self.band_cols), block[self.pair])
            p = self.values[0::3]
            coupling = (s[:, self.local, 0, None] * p[:-1, None, :]
                        + s[:, self.local, 3, None] * p[1:, None, :])  # (M−1, 4, 2)
            rhs = np.zeros((self.n_free, 2))
            np.add.at(rhs, self.rhs_index[self.rhs_valid], -coupling[self.rhs_valid])
            free = scipy.linalg.solveh_banded(band, rhs, check_finite=False)  # (2(M−2), 2)
            values[4:-3:3] = free[0::2]
            values[5:-3:3] = free[1::2]
        z = d[:, :, None] * values[self.index]  # (M−1, 6, 2): the sum of ≥ 0 terms
        cost = float(np.sum(h**-5 * np.einsum("kic,ij,kjc->k", z, JERK_GRAM, z)))
        return cost, values

    def gradient(self, h: np.ndarray, values: np.ndarray) -> np.ndarray:
        """∂J/∂h_k at the inner optimum (envelope theorem): y_kᵀ dS_k/dh y_k, (M−1,)."""
        d, dd = _scales(h)
        y = values[self.index]  # (M−1, 6, 2)
        z = d[:, :, None] * y
        dz = dd[:, :, None] * y
        kz = np.einsum("ij,kjc->kic", JERK_GRAM, z)
        return (-5.0 * h**-6 * np.einsum("kic,kic->k", z, kz)
                + 2.0 * h**-5 * np.einsum("kic,kic->k", dz, kz))


def passage_times(points: np.ndarray, start: np.ndarray | None = None,
                  ftol: float = FTOL) -> tuple[np.ndarray, np.ndarray, dict]:
    """Optimal durations h (M−1,), Σh = 1, of the minimum-jerk spline through ``points``
    (M, 2), its knot values (3M, 2) and solver figures (see the module docstring), from
    the durations ``start`` (default: ∝ chord length)."""
    chord = np.linalg.norm(np.diff(points, axis=0), axis=1)
    length = float(chord.sum()) or 1.0
    spline = _Spline((points - points[0]) / length)  # unit length: J of order 1
    start = chord if start is None else start
    theta0 = np.log(np.maximum(start, 1e-9 * start.max()))

    def durations(theta: np.ndarray) -> np.ndarray:
        e = np.exp(theta - theta.max())
        return e / e.sum()

    def objective(theta: np.ndarray) -> tuple[float, np.ndarray]:
        h = durations(theta)
        cost, values = spline.solve(h)
        g = spline.gradient(h, values) / cost  # ∂ log J / ∂h
        return math.log(cost), h * (g - np.dot(g, h))

    result = scipy.optimize.minimize(objective, theta0, jac=True, method="L-BFGS-B",
                                     options={"maxiter": MAX_ITER, "ftol": ftol,
                                              "gtol": 1e-12})
    h = durations(result.x)
    cost, values = spline.solve(h)
    values = values * length
    values[0::3] += points[0]
    return h, values, {"jerk_cost": cost * length**2, "iterations": int(result.nit)}


def _arc(points: np.ndarray) -> np.ndarray:
    """Cumulative chord length of ``points`` (M, 2), normalised to [0, 1]."""
    s = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))))
    return s / s[-1]


def coarse_to_fine(path: np.ndarray, spacing: float, max_turn: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Via points (M, 2) of ``path`` and their optimal durations and knot values
    (:func:`passage_times`), solved coarse to fine: the via points at 2^l × ``spacing`` and
    ``max_turn`` for l = L..0 (the coarsest with ≤ ``COARSEST`` points), each level
    started from the previous level's timing law t(s) (PCHIP in normalised arc length).
    The timing law's slow, path-long modes are what a first-order method converges on
    slowly; a coarse level settles them in a few iterations."""
    levels = [via_points(path, spacing, max_turn)]
    while len(levels[-1]) > COARSEST:
        scale = 2.0 ** len(levels)
        levels.append(via_points(path, spacing * scale, max_turn * scale))
    start, arc, h, iterations = None, None, np.empty(0), []
    for points in reversed(levels):
        if start is not None:
            law = PchipInterpolator(arc, np.concatenate(([0.0], np.cumsum(h))))
            start = np.maximum(np.diff(law(_arc(points))), 1e-9)
        h, values, info = passage_times(points, start)
        start, arc = h, _arc(points)
        iterations.append(info["iterations"])
    info.update(iterations=iterations, via_points=len(points))
    return points, h, values, info


def evaluate_spline(h: np.ndarray, values: np.ndarray, t: np.ndarray) -> list[np.ndarray]:
    """Position, velocity, acceleration and jerk (n, 2) each of the quintic spline with
    durations h (M−1,) and knot values (3M, 2) at times ``t`` (n,) in [0, Σh]."""
    knots = np.concatenate(([0.0], np.cumsum(h)))
    k = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(h) - 1)
    d, _ = _scales(h)
    z = d[:, :, None] * values[3 * np.arange(len(h))[:, None] + np.arange(6)]  # (M−1, 6, 2)
    coeffs = np.einsum("ij,kjc->kic", BASIS, z)[k]  # (n, 6, 2)
    tau = np.clip((t - knots[k]) / h[k], 0.0, 1.0)
    out = []
    for order in range(4):
        powers = np.stack([math.perm(j, order) * tau ** max(j - order, 0) if j >= order
                           else np.zeros_like(tau) for j in range(6)], axis=1)  # (n, 6)
        out.append(np.einsum("nj,njc->nc", powers, coeffs) / h[k][:, None] ** order)
    return out


def given_passage_times(path: np.ndarray, times: np.ndarray, spacing: float,
                        max_turn: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Via points (M, 2) of ``path`` and the minimum-jerk spline through them with the
    passage times the path's own timing gives (``times`` (N,) of its samples), not
    re-optimised: durations h ∝ the differences of those times (Σh = 1), the knot values
    the inner problem's optimum for them. The variant of the paper's comparison that
    keeps the ΣΛ timing law and only smooths between the via points."""
    points, at = via_points_and_times(path, times, spacing, max_turn)
    assert at is not None
    h = np.maximum(np.diff(at), 1e-9 * max(float(at[-1] - at[0]), 1e-12))
    h = h / h.sum()
    chord = np.linalg.norm(np.diff(points, axis=0), axis=1)
    length = float(chord.sum()) or 1.0
    cost, values = _Spline((points - points[0]) / length).solve(h)
    values = values * length
    values[0::3] += points[0]
    return points, h, values, {"jerk_cost": cost * length**2, "iterations": [0],
                               "via_points": len(points)}


def minimum_jerk_timing(path: np.ndarray, v_max: float, a_max: float, rate: float = 1000.0,
                        *, spacing: float = SPACING, max_turn: float = MAX_TURN,
                        times: np.ndarray | None = None) -> TimedPath:
    """The path-constrained minimum-jerk timing of the polyline ``path`` (N, 2+) through
    its :func:`via_points`, uniformly time-scaled so |v| ≤ v_max and |a| ≤ a_max (peaks
    measured on ``PEAK_SAMPLES`` per piece, at ``SAFETY``, then checked on the control
    samples) and sampled at ``rate``; position, velocity, acceleration and jerk are the
    spline's own (analytic).

    The passage times are optimised (the exact path-constrained minimum jerk), or, given
    the path's sample ``times`` (N,), taken from them (:func:`given_passage_times`)."""
    if times is None:
        points, h, values, info = coarse_to_fine(path, spacing, max_turn)
    else:
        points, h, values, info = given_passage_times(path, times, spacing, max_turn)
    tau = (np.arange(PEAK_SAMPLES) + 0.5) / PEAK_SAMPLES
    fine = (np.concatenate(([0.0], np.cumsum(h)))[:-1, None] + h[:, None] * tau).ravel()
    _, v, a, _ = evaluate_spline(h, values, fine)
    k, limiting = time_scale(*peaks(v, a), SAFETY * v_max, SAFETY * a_max)
    k = k or 1.0
    for _ in range(5):
        t, stretch = control_samples(k, rate)
        k_robot = k * stretch
        x, v, a, j = evaluate_spline(h, values, np.minimum(t / k_robot, 1.0))
        v, a, j = v / k_robot, a / k_robot**2, j / k_robot**3
        speed, acc = peaks(v, a)
        worst = max(speed / v_max, math.sqrt(acc / a_max))
        if worst <= 1.0:
            break
        k = k_robot * worst * (1.0 + 1e-6)
    else:
        raise AssertionError(f"minimum-jerk time scale {k} does not converge")  # pragma: no cover
    info.update(time_scale=k_robot, limiting=limiting)
    name = "minimum-jerk" if times is None else "minimum-jerk-sigma-times"
    return TimedPath(t, x, v, a, j, name, info)
