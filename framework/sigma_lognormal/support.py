"""Where a motor plan moves: the evaluated support of its lognormals and the grid on which
its peaks are measured (shared by every timing that scales a plan to limits: the robot's,
the plotter's, the evaluation's).

Support. Sub-movement i is evaluated over τ = t − t0_i ∈ [e^{μ_i−5σ_i}, e^{μ_i+5σ_i}]
(``SUPPORT_SIGMAS``), so the plan rests at p0 before t_a = min_i t0_i + e^{μ_i−5σ_i} and at
p_m after t_b = max_i t0_i + e^{μ_i+5σ_i}, with a speed below 2·10⁻⁵ of its peak there.

Grid. Each sub-movement's own ln τ is its natural scale: z ∈ [−5, 5] in steps of 0.025 σ
(``GRID_POINTS``), t = t0_i + exp(μ_i + σ_i z); a peak of speed or acceleration measured on
the union of these grids is within 2·10⁻⁴ of the true one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.kinematics import SUPPORT_SIGMAS
from inkmotion.sigma_lognormal.plan import MotorPlan

#: points of each sub-movement's ln τ grid, z ∈ [−5, 5] σ (Δz = 0.025)
GRID_POINTS = 401


@dataclass(frozen=True)
class Support:
    """A float64 CPU copy of a plan, its support [t_a, t_b] (plan s) and its peak grid (G,)."""

    plan: MotorPlan
    t_a: float
    t_b: float
    grid: np.ndarray


def support(plan: MotorPlan) -> Support:
    """The support and peak grid of ``plan`` (module docstring), on a float64 CPU copy."""
    p = plan.detached().to(device="cpu", dtype=torch.float64)
    sigma, mu, t0 = (x.numpy() for x in PlanBatch.from_plans([p]).timing())
    z = np.linspace(-SUPPORT_SIGMAS, SUPPORT_SIGMAS, GRID_POINTS)
    grid = t0[:, None] + np.exp(mu[:, None] + sigma[:, None] * z)  # (m, G)
    return Support(p, float(grid[:, 0].min()), float(grid[:, -1].max()),
                   np.unique(grid.ravel()))
