"""Kinematics benchmark: forward+backward time, and how it grows with m."""

from __future__ import annotations

import statistics
import time

import torch

from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.kinematics import batch_kinematics, uniform_times
from inkmotion.sigma_lognormal.plan import MotorPlan


def _plan(m: int, seed: int = 0) -> PlanBatch:
    g = torch.Generator().manual_seed(seed)
    steps = torch.randn(m + 1, 2, generator=g) * 20.0
    plan = MotorPlan.from_points(torch.cumsum(steps, 0))
    plan.delta.uniform_(-1.0, 1.0, generator=g)
    plan.delta_t.uniform_(0.3, 0.9, generator=g)
    return PlanBatch.from_plans([plan])


def time_forward_backward(m: int, samples_per_move: int = 5, repeats: int = 30) -> float:
    """Median ms of kinematics forward+backward on the fitting grid n = 5m (one path)."""
    src = _plan(m)
    leaves = [t.clone().requires_grad_(True) for t in (src.points, src.delta_t, src.delta)]
    batch = PlanBatch(leaves[0], leaves[1], leaves[2], src.ac, src.T, src.moves, src.widths)
    times_ms = []
    for i in range(repeats + 3):
        t0 = time.perf_counter()
        times, counts, _ = uniform_times(batch, samples_per_move)
        kin = batch_kinematics(batch, times, counts)
        (kin.positions.sum() + kin.velocities.square().sum() * 1e-3).backward()
        if i >= 3:
            times_ms.append((time.perf_counter() - t0) * 1e3)
        for leaf in leaves:
            leaf.grad = None
    return statistics.median(times_ms)


def bench_kinematics() -> dict[str, float]:
    """Figures for the targets: m = 150 (n = 750) ≤ 10 ms; cost(2000) ≤ 6 × cost(500)."""
    ms150 = time_forward_backward(150)
    ms500 = time_forward_backward(500, repeats=15)
    ms2000 = time_forward_backward(2000, repeats=8)
    return {"kinematics_m150_ms": ms150, "kinematics_m500_ms": ms500,
            "kinematics_m2000_ms": ms2000, "kinematics_ratio_2000_500": ms2000 / ms500}
