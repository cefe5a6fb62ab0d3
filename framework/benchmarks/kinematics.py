"""Kinematics benchmark: forward+backward time, how it grows with m, and host syncs."""

from __future__ import annotations

import statistics
import time

import torch

from inkmotion.profiling.host_syncs import count_host_syncs
from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch
from inkmotion.sigma_lognormal.kinematics import batch_kinematics, plan_window, uniform_times
from inkmotion.sigma_lognormal.plan import MotorPlan


def _plan(m: int, seed: int = 0, device: torch.device | str = "cpu") -> PlanBatch:
    g = torch.Generator().manual_seed(seed)
    steps = torch.randn(m + 1, 2, generator=g) * 20.0
    plan = MotorPlan.from_points(torch.cumsum(steps, 0))
    plan.delta.uniform_(-1.0, 1.0, generator=g)
    plan.delta_t.uniform_(0.3, 0.9, generator=g)
    return PlanBatch.from_plans([MotorPlan(*(getattr(plan, k).to(device) for k in (
        "points", "delta_t", "delta", "ac", "T")), plan.width)])


def synchronize(device: torch.device | str) -> None:
    """Wait for the device's queued work (before reading a clock); nothing on the CPU."""
    if torch.device(device).type == "cuda":
        torch.cuda.synchronize(device)


def _leaves(src: PlanBatch) -> tuple[PlanBatch, list[torch.Tensor]]:
    leaves = [t.clone().requires_grad_(True) for t in (src.points, src.delta_t, src.delta)]
    return PlanBatch(leaves[0], leaves[1], leaves[2], src.ac, src.T, src.moves,
                     src.widths), leaves


def _layout(batch: PlanBatch, samples_per_move: int, static: bool) -> GridLayout:
    """The fit's layout (built once per fit), with a static window if ``static``."""
    layout = batch.layout(samples_per_move=samples_per_move)
    if static:
        with torch.no_grad():
            layout = plan_window(batch, uniform_times(batch, layout)[0], layout)
    return layout


def _step(batch: PlanBatch, layout: GridLayout, leaves: list[torch.Tensor]) -> None:
    times, _ = uniform_times(batch, layout)
    kin = batch_kinematics(batch, times, layout)
    (kin.positions.sum() + kin.velocities.square().sum() * 1e-3).backward()
    for leaf in leaves:
        leaf.grad = None


def time_forward_backward(m: int, samples_per_move: int = 5, repeats: int = 30,
                          device: torch.device | str = "cpu",
                          static: bool | None = None) -> float:
    """Median ms of kinematics forward+backward on the fitting grid n = 5m (one path), the
    layout built once as in a fit; a static window off the CPU unless ``static`` says."""
    static = torch.device(device).type != "cpu" if static is None else static
    batch, leaves = _leaves(_plan(m, device=device))
    layout = _layout(batch, samples_per_move, static)
    times_ms = []
    for i in range(repeats + 3):
        synchronize(device)
        t0 = time.perf_counter()
        _step(batch, layout, leaves)
        synchronize(device)
        if i >= 3:
            times_ms.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times_ms)


def host_syncs_per_step(m: int = 150, device: torch.device | str = "cpu",
                        static: bool | None = None) -> int:
    """Host synchronisations of one kinematics forward+backward (after the layout)."""
    static = torch.device(device).type != "cpu" if static is None else static
    batch, leaves = _leaves(_plan(m, device=device))
    layout = _layout(batch, 5, static)
    with count_host_syncs() as log:
        _step(batch, layout, leaves)
    return log.count


def bench_kinematics(device: torch.device | str = "cpu") -> dict[str, float]:
    """Figures for the targets: m = 150 (n = 750) ≤ 10 ms; cost(2000) ≤ 6 × cost(500); and
    the host syncs of a kinematics step and of a whole fit step (forward+backward of the
    objective), in the mode used on ``device`` and with static shapes."""
    from inkmotion.profiling.problem import fit_problem, step_host_syncs

    ms150 = time_forward_backward(150, device=device)
    ms500 = time_forward_backward(500, repeats=15, device=device)
    ms2000 = time_forward_backward(2000, repeats=8, device=device)
    return {"kinematics_m150_ms": ms150, "kinematics_m500_ms": ms500,
            "kinematics_m2000_ms": ms2000, "kinematics_ratio_2000_500": ms2000 / ms500,
            "kinematics_host_syncs": host_syncs_per_step(device=device),
            "step_host_syncs": step_host_syncs(*fit_problem(device)).count,
            "step_host_syncs_static": step_host_syncs(*fit_problem(device, static=True)).count}
