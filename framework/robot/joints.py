"""The joint trajectory of a whole drawing: Gauss–Newton on Pinocchio's Panda (paper,
"Executing ΣΛ trajectories with a robot": iLQR solved by a Gauss–Newton scheme, with
end-effector orientation control and joint-limit avoidance).

The unknowns are joint configurations q_k (7,) at knots τ_k, a subset of the control
samples (``knot_rate`` Hz, 100 by default, refined where needed). The cost is an integral
over the drawing, with trapezoid weights w_k = (h_{k−1} + h_k)/2, h_k = τ_{k+1} − τ_k:

    E(Q) = ½ Σ_k w_k [ |p(q_k) − x_k|²/σ_p² + |a(q_k) + n|²/σ_o² + |q_k − q_home|²/σ_h² ]
         + ½ Σ_k h_k |(q_{k+1} − q_k)/h_k|²/σ_v² + ½ Σ_k w_k |q̈_k|²/σ_a²
         − μ Σ_k w_k Σ_j [ln(q_kj − l_j) + ln(u_j − q_kj)]

p the pen tip, a the pen axis (|a + n|² = 4 sin²(θ/2), θ the tilt from −n: it does not
see the rotation about the pen axis, which stays free, and its only minimum is θ = 0),
q̈_k the second difference on the uneven grid, [l, u] the joint limits shrunk by the
margin. The log-barrier keeps every iterate strictly inside the limits, and its gradient
pushes the redundant degrees of freedom away from them (joint-limit avoidance) while the
tracking terms, 10⁸ times stiffer, are left unaffected.

Each Gauss–Newton step solves (Σ_k w_k J_kᵀJ_k + D ⊗ I₇ + ∇²barrier) δ = −∇E, a banded
symmetric positive-definite system (bandwidth 20: q̈ couples knots k ± 2), by a banded
Cholesky factorisation — O(K) time and memory — with a backtracking line search that keeps
the iterate inside the barrier. The knots are joined by a C² cubic spline at the control
rate, the pen pose is verified at every control sample by forward kinematics, and knots are
inserted into the intervals that miss the tolerance.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.interpolate import CubicSpline

from inkmotion.errors import InputError
from inkmotion.robot.kinematics import (
    PenModel,
    check_reachable,
    pen_jacobians,
    pen_model,
    pen_poses,
)
from inkmotion.robot.limits import first_outside, joint_limit_ratios
from inkmotion.robot.types import JointTrajectory

_DOF = 7
_BANDWIDTH = 3 * _DOF - 1  # upper bandwidth of the Hessian: knots k and k + 2
_IK_STEP = 0.2  # rad, trust region of a single-pose solve from far away


@dataclass(frozen=True)
class TrackingWeights:
    """The scales σ of the cost's terms (each residual is divided by its σ): a pen-tip error
    of σ_p costs as much as a joint speed of σ_v over the same time."""

    position: float = 1e-5  # σ_p, m
    orientation: float = 1e-4  # σ_o, rad (tilt of the pen axis)
    velocity: float = 1.0  # σ_v, rad/s
    acceleration: float = 10.0  # σ_a, rad/s²
    posture: float = 1.0  # σ_h, rad from the home configuration
    barrier: float = 1e-3  # μ of the joint-limit log-barrier


@dataclass(frozen=True)
class _Problem:
    """What stays fixed while the knots move."""

    pen: PenModel
    home: np.ndarray  # (7,) the posture the redundancy is pulled toward
    lower: np.ndarray  # (7,) joint limits shrunk by the margin
    upper: np.ndarray  # (7,)
    weights: TrackingWeights


@dataclass(frozen=True)
class _Knots:
    """One knot grid: which control samples, where, and the smoothing operator."""

    index: np.ndarray  # (K,) control samples of the knots
    tau: np.ndarray  # (K,) s
    target: np.ndarray  # (K, 3) m
    normal: np.ndarray  # (K, 3) unit: the pen points along −normal[k] at knot k
    weight: np.ndarray  # (K,) trapezoid weights w_k, s
    smoothing: sp.csr_matrix  # (K, K) D: ½ Σ_j Q[:, j]ᵀ D Q[:, j] = velocity + acceleration
    fixed_first: bool  # q_0 is given (the robot's current configuration)


def smoothing_matrix(tau: np.ndarray, weights: TrackingWeights) -> sp.csr_matrix:
    """D (K, K) with ½ qᵀDq = ½ Σ h_k (Δq_k/h_k)²/σ_v² + ½ Σ w_k q̈_k²/σ_a² for one joint,
    where q̈_k = 2[(q_{k+1} − q_k)/h_k − (q_k − q_{k−1})/h_{k−1}]/(h_{k−1} + h_k)."""
    k = len(tau)
    if k < 2:
        return sp.csr_matrix((k, k))
    h = np.diff(tau)
    first = sp.diags([-1.0 / h, 1.0 / h], [0, 1], shape=(k - 1, k))
    velocity = first.T @ sp.diags(h / weights.velocity**2) @ first
    if k < 3:
        return velocity.tocsr()
    left, right = h[:-1], h[1:]
    scale = 2.0 / (left + right)
    second = sp.diags([scale / left, -scale * (1.0 / left + 1.0 / right), scale / right],
                      [0, 1, 2], shape=(k - 2, k))
    w_inner = (left + right) / 2.0
    acceleration = second.T @ sp.diags(w_inner / weights.acceleration**2) @ second
    return (velocity + acceleration).tocsr()


def _make_knots(index: np.ndarray, t: np.ndarray, position: np.ndarray, normal: np.ndarray,
                weights: TrackingWeights, fixed_first: bool) -> _Knots:
    tau = t[index]
    weight = np.ones(len(index))
    if len(index) > 1:
        h = np.diff(tau)
        weight = np.concatenate([h, [0.0]]) / 2.0 + np.concatenate([[0.0], h]) / 2.0
    return _Knots(index, tau, position[index], normal[index], weight,
                  smoothing_matrix(tau, weights), fixed_first)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis (broadcast), without ``np.cross``'s per-call overhead."""
    return (a[..., [1, 2, 0]] * b[..., [2, 0, 1]]) - (a[..., [2, 0, 1]] * b[..., [1, 2, 0]])


def _pen_residuals(problem: _Problem, q: np.ndarray, target: np.ndarray, normal: np.ndarray,
                   data: object = None) -> tuple[np.ndarray, np.ndarray]:
    """The scaled pen residuals r (K, 6) at q (K, 7) and their Jacobians (K, 6, 7):
    position (p − x)/σ_p with rows J_v/σ_p, axis (a + n)/σ_o with columns (J_ω,j × a)/σ_o
    (ȧ = ω × a; rank 2, the rotation about a is free); ``normal`` (K, 3) the n per knot."""
    positions, axes, jac = pen_jacobians(problem.pen, q, data)
    w = problem.weights
    r = np.concatenate([(positions - target) / w.position,
                        (axes + normal) / w.orientation], axis=1)
    j_axis = _cross(np.swapaxes(jac[:, 3:], 1, 2), axes[:, None, :])  # (K, 7, 3)
    j = np.concatenate([jac[:, :3] / w.position, np.swapaxes(j_axis, 1, 2) / w.orientation],
                       axis=1)
    return r, j


def _minimum_norm_step(r: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Per knot, δ = −J⁺r (K, 7): the smallest joint change that zeroes the linearised pen
    residuals in the least-squares sense (pseudo-inverse, singular values below 10⁻¹⁰ of
    the largest dropped: the axis rows have rank 2)."""
    return -np.einsum("kji,ki->kj", np.linalg.pinv(j, rcond=1e-10), r)


def _task_terms(problem: _Problem, q: np.ndarray, knots: _Knots
                ) -> tuple[float, np.ndarray, np.ndarray]:
    """The per-knot part of E at q (K, 7): its value, gradient (K, 7) and Gauss–Newton
    Hessian blocks (K, 7, 7), w_k (JᵀJ + I/σ_h²)."""
    r, j = _pen_residuals(problem, q, knots.target, knots.normal)
    w, sigma_h = knots.weight, problem.weights.posture
    r_home = (q - problem.home) / sigma_h
    value = 0.5 * float(w @ (np.sum(r**2, axis=1) + np.sum(r_home**2, axis=1)))
    grad = w[:, None] * (np.einsum("kij,ki->kj", j, r) + r_home / sigma_h)
    blocks = w[:, None, None] * (np.einsum("kij,kil->kjl", j, j) + np.eye(_DOF) / sigma_h**2)
    return value, grad, blocks


def _barrier(problem: _Problem, q: np.ndarray, weight: np.ndarray
             ) -> tuple[float, np.ndarray, np.ndarray]:
    """−μ Σ w_k Σ_j [ln(q − l) + ln(u − q)], its gradient and Hessian diagonal (K, 7);
    +∞ outside the open box."""
    below, above = q - problem.lower, problem.upper - q
    if np.any(below <= 0.0) or np.any(above <= 0.0):
        return np.inf, np.zeros_like(q), np.zeros_like(q)
    w = problem.weights.barrier * weight[:, None]
    value = -float(np.sum(w * (np.log(below) + np.log(above))))
    return value, w * (1.0 / above - 1.0 / below), w * (1.0 / below**2 + 1.0 / above**2)


def _cost_value(problem: _Problem, q: np.ndarray, knots: _Knots) -> float:
    """E(Q) alone (forward kinematics only), for the line search."""
    barrier, _, _ = _barrier(problem, q, knots.weight)
    if not np.isfinite(barrier):
        return np.inf
    w = problem.weights
    positions, axes = pen_poses(problem.pen, q)
    r2 = (np.sum((positions - knots.target) ** 2, axis=1) / w.position**2
          + np.sum((axes + knots.normal) ** 2, axis=1) / w.orientation**2
          + np.sum((q - problem.home) ** 2, axis=1) / w.posture**2)
    return 0.5 * float(knots.weight @ r2) + 0.5 * float(np.sum(q * (knots.smoothing @ q))) \
        + barrier


def _linearise(problem: _Problem, q: np.ndarray, knots: _Knots
               ) -> tuple[float, np.ndarray, sp.csr_matrix]:
    """E(Q), its gradient (K·7,) and Gauss–Newton Hessian (K·7, K·7), knot-major."""
    b_value, b_grad, b_hess = _barrier(problem, q, knots.weight)
    assert np.isfinite(b_value), "iterates stay strictly inside the limits"
    t_value, t_grad, blocks = _task_terms(problem, q, knots)
    blocks[:, np.arange(_DOF), np.arange(_DOF)] += b_hess
    k = len(q)
    rows = np.broadcast_to(np.arange(k * _DOF).reshape(k, _DOF, 1), blocks.shape)
    cols = np.swapaxes(rows, 1, 2)
    hessian = sp.coo_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())),
                            shape=(k * _DOF, k * _DOF)).tocsr()
    hessian = hessian + sp.kron(knots.smoothing, sp.eye(_DOF), format="csr")
    smooth = knots.smoothing @ q  # (K, 7)
    value = t_value + 0.5 * float(np.sum(q * smooth)) + b_value
    return value, (t_grad + smooth + b_grad).ravel(), hessian


def _upper_banded(matrix: sp.spmatrix, bandwidth: int) -> np.ndarray:
    """LAPACK's upper banded storage ab[bandwidth + i − j, j] = A[i, j] of a symmetric A."""
    n = matrix.shape[0]
    ab = np.zeros((bandwidth + 1, n))
    for offset in range(min(bandwidth, n - 1) + 1):
        ab[bandwidth - offset, offset:] = matrix.diagonal(offset)
    return ab


def _gauss_newton(problem: _Problem, q: np.ndarray, knots: _Knots, max_iterations: int,
                  step_tolerance: float = 1e-9, max_step: float = np.inf
                  ) -> tuple[np.ndarray, int]:
    """Minimise E from q (K, 7), strictly inside the limits; returns (q, iterations).

    Step δ = −H⁻¹∇E (banded Cholesky; the first knot's rows dropped when it is fixed),
    then α ∈ {1, ½, ¼, ...}: at most 0.95 of the way to the barrier's wall and Armijo's
    E(q⁺) ≤ E(q) + 10⁻⁴ α ∇Eᵀδ, where q⁺ = q + αδ plus a second-order correction: the
    per-knot minimum-norm step back onto the pen path. Without it, the steps that move the
    redundant joints along the curved set {p(q) = x, a(q) = −n} leave O(|δ|²) tracking
    errors that the stiff tracking terms penalise, and the line search crawls. Stops when
    the step or the relative decrease of E falls below round-off (10⁻⁹).
    """
    free = slice(_DOF if knots.fixed_first else 0, None)
    if q[free].size == 0:
        return q, 0
    value, grad, hessian = _linearise(problem, q, knots)
    for iteration in range(1, max_iterations + 1):
        g = grad[free]
        step = np.zeros(q.size)
        step[free] = scipy.linalg.solveh_banded(
            _upper_banded(hessian[free, free], _BANDWIDTH), -g)
        step = _limited(step.reshape(q.shape), max_step)
        if np.max(np.abs(step)) < step_tolerance:
            return q, iteration
        slope = float(g @ step.ravel()[free])
        alpha = _max_feasible_step(problem, q, step)
        while True:
            trial = _corrected(problem, q + alpha * step, knots)
            trial_value = _cost_value(problem, trial, knots)
            if trial_value <= value + 1e-4 * alpha * slope or alpha < 1e-6:
                break
            alpha *= 0.5
        if not trial_value < value:  # no descent left: converged to round-off
            return q, iteration
        q, decrease = trial, value - trial_value
        value, grad, hessian = _linearise(problem, q, knots)
        if alpha * np.max(np.abs(step)) < step_tolerance or decrease <= 1e-9 * abs(value):
            return q, iteration
    return q, max_iterations


def _limited(step: np.ndarray, max_step: float) -> np.ndarray:
    """``step`` scaled down so that no joint moves more than ``max_step`` rad."""
    largest = float(np.max(np.abs(step)))
    return step * (max_step / largest) if largest > max_step else step


def _corrected(problem: _Problem, q: np.ndarray, knots: _Knots) -> np.ndarray:
    """q + the per-knot minimum-norm step onto the pen path, where it stays inside the
    limits (else q unchanged at that knot); a fixed first knot is left as it is."""
    r, j = _pen_residuals(problem, q, knots.target, knots.normal)
    moved = q + _minimum_norm_step(r, j)
    inside = np.all((moved > problem.lower) & (moved < problem.upper), axis=1)
    inside[0] &= not knots.fixed_first
    return np.where(inside[:, None], moved, q)


def _max_feasible_step(problem: _Problem, q: np.ndarray, step: np.ndarray) -> float:
    """The largest α ≤ 1 that goes at most 95 % of the way to the nearest limit."""
    with np.errstate(divide="ignore", invalid="ignore"):
        to_wall = np.where(step > 0, (problem.upper - q) / step,
                           np.where(step < 0, (problem.lower - q) / step, np.inf))
    return float(min(1.0, 0.95 * np.min(to_wall)))


def _sweep(problem: _Problem, q0: np.ndarray, targets: np.ndarray, normals: np.ndarray,
           steps: int = 1, max_step: float = np.inf) -> np.ndarray:
    """Warm start (K, 7): knot by knot from q0, ``steps`` minimum-norm steps on the pen
    residuals from the previous knot's solution (so the posture changes as little as
    possible), clipped 1 % inside the limits. The knots are millimetres apart, so one step
    lands within micrometres; Gauss–Newton does the rest."""
    pad = 0.01 * (problem.upper - problem.lower)
    low, high = problem.lower + pad, problem.upper - pad
    data = problem.pen.model.createData()
    q = np.empty((len(targets), _DOF))
    current = np.clip(q0, low, high)
    for k in range(len(targets)):
        for _ in range(steps):
            r, j = _pen_residuals(problem, current[None], targets[k:k + 1],
                                  normals[k:k + 1], data)
            step = _limited(_minimum_norm_step(r, j)[0], max_step)
            current = np.clip(current + step, low, high)
        q[k] = current
    return q


def _solve_ik(problem: _Problem, target: np.ndarray, normal: np.ndarray,
              tolerances: tuple[float, float], restarts: int = 32) -> np.ndarray:
    """One pose: the configuration near home (posture term) with the pen tip at ``target``
    along −``normal``, by the same Gauss–Newton on a single knot. From home first; if that
    local solve misses the tolerances (e.g. a pen axis far from home's), from ``restarts``
    seeds drawn uniformly inside the limits (a fixed generator: deterministic), keeping the
    reaching solution nearest home — or the best miss, for the caller to report."""
    knots = _Knots(np.zeros(1, int), np.zeros(1), target[None], normal[None], np.ones(1),
                   sp.csr_matrix((1, 1)), fixed_first=False)
    seeds = np.random.default_rng(0).uniform(problem.lower, problem.upper, (restarts, _DOF))
    best, best_key = None, (np.inf, np.inf)
    for i, seed in enumerate(np.vstack([problem.home, seeds])):
        start = _sweep(problem, seed, target[None], normal[None], steps=20, max_step=_IK_STEP)
        q, _ = _gauss_newton(problem, start, knots, max_iterations=50, max_step=_IK_STEP)
        pos_err, ang_err = _pose_errors(problem, q, target[None], normal[None])
        miss = max(pos_err[0] / tolerances[0], ang_err[0] / tolerances[1])
        if i == 0 and miss <= 1.0:
            return q[0]
        key = (max(miss, 1.0), float(np.linalg.norm(q[0] - problem.home)))
        if key < best_key:
            best, best_key = q[0], key
    return best


def _pose_errors(problem: _Problem, q: np.ndarray, target: np.ndarray,
                 normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pen-tip distance (N,) m and pen-axis angle to −normal (N,) rad (``normal`` (N, 3))."""
    positions, axes = pen_poses(problem.pen, q)
    angle = np.arctan2(np.linalg.norm(_cross(axes, normal), axis=1),
                       -np.sum(axes * normal, axis=1))
    return np.linalg.norm(positions - target, axis=1), angle


def _interpolate(tau: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """q (K, 7) at knots τ as a C² cubic spline with zero end velocities (the drawing
    starts and ends at rest), sampled at t (N,)."""
    if len(tau) == 1:
        return np.repeat(q, len(t), axis=0)
    return CubicSpline(tau, q, axis=0, bc_type="clamped")(t)


def _refine(index: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """Knot indices with the midpoint of every interval that holds a bad sample added."""
    interval = np.clip(np.searchsorted(index, bad, side="right") - 1, 0, len(index) - 2)
    interval = np.unique(interval)
    left, right = index[interval], index[interval + 1]
    wide = right - left >= 2
    return np.union1d(index, (left[wide] + right[wide]) // 2)


def _unreachable(where: int, target: np.ndarray, t: float, pos_err: float,
                 ang_err: float, stroke: np.ndarray | None, turning: bool = False
                 ) -> InputError:
    label = f"sample {where} (t = {t:.3f} s"
    if stroke is not None and int(stroke[where]) >= 0:
        label += f", stroke {int(stroke[where])}"
    x, y, z = target
    how = ("on its way from the home pose, turning the pen from home's axis to the "
           "drawing plane's normal," if turning else "normal to the drawing plane")
    fix = (" or teach a home pose whose pen points nearer the plane's normal" if turning
           else "")
    return InputError(
        f"The Panda cannot hold the pen at {label}), ({x:.3f}, {y:.3f}, {z:.3f}) m in the "
        f"base frame, {how} inside its joint limits (off by "
        f"{pos_err * 1e3:.2f} mm and {np.degrees(ang_err):.2f}°); move the drawing plane "
        "closer to the robot or nearer its home pen pose, scale the paper down, reduce "
        f"joint_margin{fix}.")


def _start(problem: _Problem, first: np.ndarray, normal: np.ndarray,
           q_start: np.ndarray | None, tolerances: tuple[float, float]) -> np.ndarray:
    """The first knot: q_start as given (checked), or the IK solution nearest home."""
    if q_start is None:
        return _solve_ik(problem, first, normal, tolerances)
    q0 = np.asarray(q_start, dtype=float)
    j = first_outside(q0, problem.lower, problem.upper)
    if j is not None:
        raise InputError(f"The start pose (the setup's [robot] home, or the arm's own) has "
                         f"joint {j + 1} at {q0[j]:.4f} rad, outside this arm's range "
                         f"{problem.lower[j]:.4f} to {problem.upper[j]:.4f} rad (its limits "
                         "less joint_margin); give a home inside it, or reduce joint_margin.")
    pos_err, ang_err = _pose_errors(problem, q0[None], first[None], normal[None])
    if pos_err[0] > tolerances[0] or ang_err[0] > tolerances[1]:
        raise InputError(
            f"q_start puts the pen tip {pos_err[0] * 1e3:.2f} mm and "
            f"{np.degrees(ang_err[0]):.2f}° off the trajectory's first sample; start the "
            "Cartesian trajectory at the robot's current pen pose.")
    return q0


def solve_joint_trajectory(target: object, *, pen_length: float, home: np.ndarray,
                           joint_margin: float = 0.05, q_start: np.ndarray | None = None,
                           knot_rate: float = 100.0, position_tolerance: float = 5e-4,
                           orientation_tolerance: float = np.radians(2.0),
                           weights: TrackingWeights | None = None, max_iterations: int = 30,
                           max_refinements: int = 4,
                           position_limits: tuple[np.ndarray, np.ndarray] | None = None
                           ) -> JointTrajectory:
    """Joint positions at every control sample of ``target`` (a ``CartesianTrajectory``:
    ``t``, ``position`` (N, 3), ``normal``, ``rate``, optionally ``stroke`` and ``axis``)
    that keep the pen tip on the path and the pen along −normal (−axis[k] per sample where
    the trajectory has one), ``joint_margin`` rad inside the limits.

    ``position_limits``: the (lower, upper) joint ranges (7,) of the arm that will draw
    (default: the Panda URDF's); the narrower of those and the model's are used.

    The robot starts at ``q_start`` (fixed; its pen pose must match the first sample) or,
    by default, at the configuration nearest ``home`` that reaches the first sample; the
    redundancy is pulled toward ``home`` throughout. Raises ``InputError`` when a sample is
    out of reach (before any solve when the pre-check sees it, else when the tolerances
    cannot be met).
    """
    started = time.perf_counter()
    t = np.asarray(target.t, dtype=float)
    position = np.asarray(target.position, dtype=float).reshape(-1, 3)
    normals = getattr(target, "axis", None)
    if normals is None:  # −normal at every sample
        normals = np.broadcast_to(np.asarray(target.normal, dtype=float), (len(t), 3))
    normals = np.asarray(normals, dtype=float)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    plane = np.asarray(target.normal, dtype=float)
    turning = np.sum(normals * (plane / np.linalg.norm(plane)), axis=1) < 1.0 - 1e-12
    rate = float(target.rate)
    stroke = getattr(target, "stroke", None)
    assert len(t) == len(position) >= 1 and np.shape(home) == (_DOF,)
    check_reachable(position, normals, pen_length, joint_margin=joint_margin, stroke=stroke)
    pen = pen_model(float(pen_length))
    lower, upper = pen.lower, pen.upper
    if position_limits is not None:
        lower = np.maximum(lower, np.asarray(position_limits[0], dtype=float))
        upper = np.minimum(upper, np.asarray(position_limits[1], dtype=float))
    if np.any(lower + joint_margin >= upper - joint_margin):
        raise InputError(f"joint_margin = {joint_margin} rad leaves no room between the "
                         "Panda's joint limits; use a smaller margin (0.05 rad is usual).")
    problem = _Problem(pen, np.asarray(home, dtype=float), lower + joint_margin,
                       upper - joint_margin, weights or TrackingWeights())
    tolerances = (position_tolerance, orientation_tolerance)
    q0 = _start(problem, position[0], normals[0], q_start, tolerances)

    n, fixed = len(t), q_start is not None
    stride = max(1, int(round(rate / knot_rate)))
    knots = _make_knots(np.union1d(np.arange(0, n, stride), [n - 1]), t, position, normals,
                        problem.weights, fixed)
    q = _sweep(problem, q0, knots.target, knots.normal)
    q[0] = q0
    iterations, refinements = 0, 0
    while True:
        q, used = _gauss_newton(problem, q, knots, max_iterations)
        iterations += used
        knot_pos, knot_ang = _pose_errors(problem, q, knots.target, knots.normal)
        miss = np.flatnonzero((knot_pos > tolerances[0]) | (knot_ang > tolerances[1]))
        if len(miss):
            k = int(miss[0])
            raise _unreachable(int(knots.index[k]), knots.target[k], knots.tau[k],
                               knot_pos[k], knot_ang[k], stroke,
                               bool(turning[knots.index[k]]))
        q_all = _interpolate(knots.tau, q, t)
        pos_err, ang_err = _pose_errors(problem, q_all, position, normals)
        bad = np.flatnonzero((pos_err > tolerances[0]) | (ang_err > tolerances[1]))
        if len(bad) == 0:
            break
        index = _refine(knots.index, bad)
        if refinements >= max_refinements or len(index) == len(knots.index):
            k = int(bad[0])
            raise _unreachable(k, position[k], t[k], pos_err[k], ang_err[k], stroke,
                               bool(turning[k]))
        refinements += 1
        q = _interpolate(knots.tau, q, t[index])
        knots = _make_knots(index, t, position, normals, problem.weights, fixed)

    ratios = joint_limit_ratios(q_all, rate)
    info = {
        "knots": int(len(knots.index)),
        "iterations": int(iterations),
        "refinements": int(refinements),
        "solve_s": time.perf_counter() - started,
        "max_velocity_ratio": ratios["velocity"].tolist(),
        "max_acceleration_ratio": ratios["acceleration"].tolist(),
        "max_jerk_ratio": ratios["jerk"].tolist(),
        "min_joint_margin": float(np.min(np.minimum(q_all - lower, upper - q_all))),
        "mean_position_error": float(np.mean(pos_err)),
        "method": "Gauss–Newton, banded Cholesky, log-barrier joint limits, C² spline",
    }
    return JointTrajectory(t=t.copy(), q=q_all, rate=rate,
                           max_position_error=float(np.max(pos_err)),
                           max_orientation_error=float(np.max(ang_err)), info=info)
