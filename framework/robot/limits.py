"""The Franka arms' motion limits (Franka's datasheets: Panda and FR3) and how a sampled
trajectory measures against them: the one place where a limit ratio is computed.

Every time derivative behind a limit figure is the n-th finite difference at the sample
rate f,

    q⁽ⁿ⁾ ≈ Δⁿq · fⁿ,   Δq_k = q_{k+1} − q_k,

the compact (n + 1)-sample stencil, centred at the middle of its samples with an error of
n h² q⁽ⁿ⁺²⁾/24 (h = 1/f), and exact for a polynomial of degree n: between the knots of
the planner's C² cubic spline, its piecewise-constant jerk comes out exactly. Repeated
central differences (``np.gradient`` n times) widen the stencil to 2n + 1 samples, with a
larger error (h² q⁽ⁿ⁺²⁾ n/6) and a blunted response to fast changes, and at the ends fall
back to one-sided differences whose composition is inconsistent (the second derivative at
the first sample is ½ Δ²q f²), which is why they are not used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkmotion.errors import InputError


@dataclass(frozen=True)
class ArmLimits:
    """One Franka model's joint limits (Franka's datasheet for that model; libfranka
    rejects a command beyond any of them with a reflex). Arrays (7,): position rad,
    velocity rad/s, acceleration rad/s², jerk rad/s³, torque N·m."""

    name: str
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    torque: np.ndarray

    def by_order(self) -> dict[str, tuple[int, np.ndarray]]:
        """The derivative limits keyed by name, with their order (1: velocity, 2:
        acceleration, 3: jerk)."""
        return {"velocity": (1, self.velocity), "acceleration": (2, self.acceleration),
                "jerk": (3, self.jerk)}


_TORQUE = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])
#: Franka Emika Panda (the model the planner and the MuJoCo simulation use)
PANDA = ArmLimits(
    "panda",
    lower=np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973]),
    upper=np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973]),
    velocity=np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]),
    acceleration=np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]),
    jerk=np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0]),
    torque=_TORQUE)
#: Franka Research 3: the Panda's kinematics (same link lengths) with its own, mostly
#: narrower, position ranges (joint 6 starts at 0.5445 rad), faster wrists and lower
#: acceleration and jerk limits
FR3 = ArmLimits(
    "fr3",
    lower=np.array([-2.7437, -1.7837, -2.9007, -3.0421, -2.8065, 0.5445, -3.0159]),
    upper=np.array([2.7437, 1.7837, 2.9007, -0.1518, 2.8065, 4.5169, 3.0159]),
    velocity=np.array([2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26]),
    acceleration=np.full(7, 10.0),
    jerk=np.full(7, 5000.0),
    torque=_TORQUE)
#: the models by name
ARMS = {arm.name: arm for arm in (PANDA, FR3)}


def arm_limits(name: str) -> ArmLimits:
    """The limits of the Franka model ``name`` ("panda" or "fr3")."""
    try:
        return ARMS[name.lower()]
    except KeyError:
        raise InputError(f"unknown Franka model {name!r} (known: {', '.join(ARMS)}); "
                         "name one of those.") from None


#: Franka Panda joint limits (datasheet): velocity rad/s, acceleration rad/s², jerk rad/s³
VELOCITY_LIMITS = PANDA.velocity
ACCELERATION_LIMITS = PANDA.acceleration
JERK_LIMITS = PANDA.jerk
#: the joint limits by derivative order (1: velocity, 2: acceleration, 3: jerk)
JOINT_LIMITS = PANDA.by_order()
def first_outside(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> int | None:
    """The first joint of ``q`` (7,) at or beyond its open range (lower, upper), or None."""
    outside = np.flatnonzero((q <= lower) | (q >= upper))
    return int(outside[0]) if len(outside) else None


#: Cartesian limits of the flange: speed m/s, acceleration m/s²
CARTESIAN_SPEED_LIMIT = 1.7
CARTESIAN_ACCELERATION_LIMIT = 13.0


def finite_difference(x: np.ndarray, rate: float, order: int) -> np.ndarray:
    """The ``order``-th time derivative of ``x`` (N, ...) sampled at ``rate`` Hz, Δⁿx·fⁿ
    (N − order, ...) (module docstring); empty when N ≤ order."""
    return np.diff(x, n=order, axis=0) * rate**order


def peak(x: np.ndarray, rate: float, order: int) -> np.ndarray:
    """max_k |Δⁿx_k|·fⁿ per column of ``x`` (N, ...) → (...); zeros when N ≤ order."""
    d = finite_difference(x, rate, order)
    if len(d) == 0:
        return np.zeros(np.shape(x)[1:])
    return np.max(np.abs(d), axis=0)


def peak_norm(x: np.ndarray, rate: float, order: int) -> float:
    """max_k ‖Δⁿx_k‖·fⁿ of points ``x`` (N, 3) (e.g. the flange's speed for order 1);
    0 when N ≤ order."""
    d = finite_difference(x, rate, order)
    return float(np.linalg.norm(d, axis=1).max()) if len(d) else 0.0


def joint_limit_ratios(q: np.ndarray, rate: float,
                       arm: ArmLimits = PANDA) -> dict[str, np.ndarray]:
    """Per joint, the peak |velocity|, |acceleration| and |jerk| of q (N, 7) sampled at
    ``rate`` Hz over ``arm``'s limits (1 = at the limit), keyed by those three names."""
    return {name: peak(q, rate, order) / limit
            for name, (order, limit) in arm.by_order().items()}


def limit_figures(name: str, peaks: np.ndarray, limit: np.ndarray) -> dict:
    """``{name}_max`` (the per-joint peaks), ``{name}_ratio`` (peaks/limit) and
    ``{name}_min_margin`` (1 − the largest ratio: how far the worst joint stays below)."""
    ratio = peaks / limit
    return {f"{name}_max": peaks.tolist(), f"{name}_ratio": ratio.tolist(),
            f"{name}_min_margin": float(1.0 - ratio.max())}
