"""One place where fitted plans leave the device: CPU copies and dense samples for writers.

Every writer (trajectory.csv, speed.png, the Chamfer figure, SVG, overlay) works on CPU
data, whatever device the fit ran on: :func:`on_cpu` moves plans once, :func:`sample`
gives NumPy arrays of the kinematics at uniform times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from inkmotion.sigma_lognormal.kinematics import kinematics
from inkmotion.sigma_lognormal.plan import MotorPlan


def on_cpu(plan: MotorPlan, dtype: torch.dtype | None = None) -> MotorPlan:
    """A detached CPU copy of ``plan`` (in ``dtype`` when given)."""
    return plan.detached().to(device="cpu", dtype=dtype)


@dataclass(frozen=True)
class Samples:
    """Kinematics of one trajectory at uniform times t_k = k·T_end/n, k = 0..n (float64)."""

    t: np.ndarray  # (n + 1,) s
    positions: np.ndarray  # (n + 1, D) px
    velocities: np.ndarray  # (n + 1, D) px/s
    accelerations: np.ndarray  # (n + 1, D) px/s²

    @property
    def speed(self) -> np.ndarray:
        """(n + 1,) planar speed |(vx, vy)|."""
        return np.hypot(self.velocities[:, 0], self.velocities[:, 1])


def sample(plan: MotorPlan, per_move: int = 20) -> Samples:
    """``plan`` sampled with n = per_move·m segments, computed in float64 on the CPU."""
    p = on_cpu(plan, torch.float64)
    with torch.no_grad():
        t = torch.linspace(0.0, float(p.end_time), per_move * p.m + 1, dtype=torch.float64)
        kin = kinematics(p, t)
    return Samples(t.numpy(), kin.positions.numpy(), kin.velocities.numpy(),
                   kin.accelerations.numpy())
