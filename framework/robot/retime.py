"""The robot program made to respect an arm's joint limits by construction: uniform
retiming of the joint reference, checked with the exact finite differences libfranka
applies.

A real Franka stops with a reflex on the first command beyond a joint's position, velocity,
acceleration or jerk limit, and libfranka checks the commanded signal by finite differences
at 1 kHz. The joint planner (:mod:`inkmotion.robot.joints`) keeps positions inside a
log-barrier and only regularises velocity and acceleration, so a fast drawing, a short
landing or a wrist turn can still ask for more than the arm allows.

Playing the program k ≥ 1 times slower, q'(t) = q(t / k), divides every n-th derivative by
kⁿ and leaves the path exactly as planned: the pen goes where the plan says, only later.
With ρ_n the largest ratio of a joint's n-th difference to its limit (the reference at rest
before it starts and after it ends, :func:`padded_ratios`, so that the steps into and out of
the motion are held to the same limits) and φ the fraction of the limits the plan may use,

    k = max(1, ρ_1/φ, (ρ_2/φ)^½, (ρ_3/φ)^⅓),

then the program is resampled at the control rate (the joints through a C² cubic spline of
the 1 kHz reference, the pen path linearly: < 1 µm at 1 kHz) and measured again; k grows by
the remaining excess until every ratio is at most φ. Positions do not change with time, so a
reference that leaves an arm's position range (less the margin) is refused, naming the
joint and the time.

Why not a quadratic programme that stays closest to the reference in joint space (OSQP):
the limits couple thousands of samples along a chain, and at a jerk limit of ~10⁻⁵ rad per
step³ at 1 kHz OSQP's ADMM did not converge on a 20 s reference (100 000 iterations, 90 s,
"maximum iterations reached", the acceleration still 1.2× its bound); and the joint change
it makes moves the pen off the planned path, whereas a retiming costs only time.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.interpolate import CubicSpline

from inkmotion.errors import InputError
from inkmotion.robot.limits import ArmLimits, finite_difference
from inkmotion.robot.types import CartesianTrajectory, JointTrajectory

#: samples of rest assumed before and after the reference (enough for a third difference)
_PAD = 3
#: the time scale is raised by this much more than the measured excess (round-off of the
#: resampled differences), and at most this many times
_GROWTH = 1.002
_MAX_ROUNDS = 20


def padded_ratios(q: np.ndarray, rate: float, arm: ArmLimits) -> dict[str, np.ndarray]:
    """Peak |Δⁿ q̄| fⁿ / L per joint (velocity, acceleration, jerk), q̄ the reference q (N, 7)
    at ``rate`` Hz held at rest for three samples before and after it."""
    q = np.asarray(q, dtype=float)
    padded = np.concatenate([np.repeat(q[:1], _PAD, axis=0), q,
                             np.repeat(q[-1:], _PAD, axis=0)])
    return {name: np.max(np.abs(finite_difference(padded, rate, order)), axis=0) / limit
            for name, (order, limit) in arm.by_order().items()}


def time_scale_for(ratios: dict[str, np.ndarray], fraction: float) -> float:
    """The smallest uniform slow-down that brings ``ratios`` to ``fraction`` (k ≥ 1)."""
    orders = {"velocity": 1, "acceleration": 2, "jerk": 3}
    return max([1.0] + [(float(np.max(r)) / fraction) ** (1.0 / orders[name])
                        for name, r in ratios.items()])


def check_positions(q: np.ndarray, rate: float, arm: ArmLimits, margin: float) -> None:
    """Refuse q (N, 7) when a joint comes within ``margin`` rad of ``arm``'s position
    range: one sentence naming the joint, the time and the limit."""
    lower, upper = arm.lower + margin, arm.upper - margin
    below, above = lower - q, q - upper
    excess = np.maximum(below, above)
    if np.all(excess <= 0):
        return
    k, j = np.unravel_index(int(np.argmax(excess)), excess.shape)
    side = "lower" if below[k, j] > 0 else "upper"
    limit = arm.lower[j] if side == "lower" else arm.upper[j]
    raise InputError(
        f"The joint trajectory takes joint {j + 1} of the {arm.name} to {q[k, j]:.4f} rad at "
        f"t = {k / rate:.3f} s, within {margin} rad of its {side} limit {limit:.4f} rad; move "
        "the drawing plane nearer the home pen pose, scale the paper down or change home.")


def _resample(cartesian: CartesianTrajectory, joints: JointTrajectory, k: float
              ) -> tuple[CartesianTrajectory, JointTrajectory]:
    """The program played ``k`` times slower, sampled at the same rate."""
    rate = cartesian.rate
    n = int(math.ceil((len(cartesian.t) - 1) * k)) + 1
    t_new = np.arange(n) / rate
    s = np.minimum(t_new / k, cartesian.t[-1])
    position = np.stack([np.interp(s, cartesian.t, cartesian.position[:, i])
                         for i in range(3)], axis=1)
    nearest = np.clip(np.round(s * rate).astype(int), 0, len(cartesian.t) - 1)
    axis = None
    if cartesian.axis is not None:
        axis = np.stack([np.interp(s, cartesian.t, cartesian.axis[:, i]) for i in range(3)],
                        axis=1)
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    cart = dataclasses.replace(cartesian, t=t_new, position=position,
                               pen_down=cartesian.pen_down[nearest],
                               stroke=cartesian.stroke[nearest],
                               time_scale=cartesian.time_scale * k,
                               info=_slowed(cartesian.info, k, n), axis=axis)
    q = CubicSpline(joints.t, joints.q, axis=0, bc_type="clamped")(s)
    return cart, dataclasses.replace(joints, t=t_new.copy(), q=q)


#: the timing's figures (inkmotion.robot.timing) that a slow-down by k scales by k^power
_SCALED = {"drawing_s": 1, "transfer_s": 1, "total_s": 1, "time_scale": 1, "peak_speed": -1,
           "drawing_peak_speed": -1, "peak_acc": -2, "drawing_peak_acc": -2}


def _slowed(info: dict, k: float, samples: int) -> dict:
    """The timing's figures of the program played ``k`` times slower: durations and the
    time scale × k, speeds / k, accelerations / k², and its new sample count (a report then
    says what the arm does, not what the drawing was first timed at)."""
    out = {**info, "retime_factor": k}
    for key, power in _SCALED.items():
        if isinstance(out.get(key), (int, float)):
            out[key] = float(out[key]) * k**power
    if "samples" in out:
        out["samples"] = samples
    return out


def fit_to_limits(cartesian: CartesianTrajectory, joints: JointTrajectory, arm: ArmLimits, *,
                  fraction: float, position_margin: float
                  ) -> tuple[CartesianTrajectory, JointTrajectory, dict]:
    """The program (its pen path and joint reference) retimed so that every joint stays
    within ``fraction`` of ``arm``'s velocity, acceleration and jerk limits and
    ``position_margin`` rad inside its range (module docstring); returns it with the
    figures: the time scale, the ratios before and after, and whether it changed."""
    rate = joints.rate
    check_positions(joints.q, rate, arm, position_margin)
    before = padded_ratios(joints.q, rate, arm)
    k = time_scale_for(before, fraction)
    cart, q_traj, after, total = cartesian, joints, before, 1.0
    rounds = 0
    while k > 1.0:
        if rounds >= _MAX_ROUNDS:
            raise InputError(f"the joint reference could not be brought within {fraction} "
                             f"of the {arm.name}'s limits by slowing it down; lower v_max "
                             "and a_max in the setup.")
        total *= k * _GROWTH
        cart, q_traj = _resample(cartesian, joints, total)
        after = padded_ratios(q_traj.q, rate, arm)
        k = time_scale_for(after, fraction)
        rounds += 1
    info = {
        "arm": arm.name,
        "limit_fraction": fraction,
        "retimed": total > 1.0,
        "retime_factor": total,
        "duration_before_s": float(joints.t[-1]),
        "duration_s": float(q_traj.t[-1]),
        "ratios_before": {name: r.tolist() for name, r in before.items()},
        "ratios": {name: r.tolist() for name, r in after.items()},
        "min_margin": float(1.0 - max(float(np.max(r)) for r in after.values())),
        "min_position_margin_rad": float(np.min(np.minimum(q_traj.q - arm.lower,
                                                           arm.upper - q_traj.q))),
    }
    return cart, q_traj, info
