"""Speed profile of a motor plan and the contribution of each lognormal (for plots).

    |v(t)|                    total speed (px/s), from the full kinematics
    Λ_i(t) · h_i · |d_i|      speed of sub-movement i alone (the bell of paper Fig. 2c),

with h_i = 1/sinc(δ_i/2π) (the arc is h_i times longer than its chord, normalised sinc)
and |d_i| the chord over x, y. Λ_i is the lognormal density at τ = t − t0_i (paper eq. 2).
The per-lognormal part is a dense (m, n) evaluation, which is fine for plotting only.
"""

from __future__ import annotations

import math

import torch

from inkmotion.portable_math import planar_norm
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.kinematics import EPS, kinematics
from inkmotion.sigma_lognormal.plan import MotorPlan

_SQRT2PI = math.sqrt(2.0 * math.pi)


def lognormal_speeds(plan: MotorPlan, t: torch.Tensor) -> torch.Tensor:
    """Λ_i(t) · h_i · |d_i| for every sub-movement i at times t (n,): (m, n)."""
    batch = PlanBatch.from_plans([plan])
    sigma, mu, t0 = batch.timing()  # (m,) each
    d = batch.displacements()[:, :2]  # (m, 2)
    t = torch.as_tensor(t, dtype=sigma.dtype, device=sigma.device).reshape(-1)
    phi = torch.relu(t[None, :] - t0[:, None] - EPS) + EPS  # (m, n)
    z = (torch.log(phi) - mu[:, None]) / sigma[:, None]
    lam = torch.exp(-0.5 * z * z) / (sigma[:, None] * _SQRT2PI * phi)
    h = 1.0 / torch.sinc(batch.delta / (2.0 * math.pi))  # (m,)
    return lam * (h * planar_norm(d))[:, None]


def speed_profile(plan: MotorPlan, t: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(total speed (n,), per-lognormal speeds (m, n)) of ``plan`` at times ``t`` (n,).

    The total is |v(t)| over x, y (the radius coordinate is not a speed on the paper).
    """
    t = torch.as_tensor(t, dtype=plan.points.dtype, device=plan.points.device).reshape(-1)
    v = kinematics(plan, t).velocities[:, :2]
    return planar_norm(v), lognormal_speeds(plan, t)
