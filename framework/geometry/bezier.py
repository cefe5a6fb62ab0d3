"""Hermite → cubic Bézier conversion of sampled trajectories.

Between samples t_k and t_k + dt the segment is
[x_k, x_k + (dt/3)·v_k, x_{k+1} − (dt/3)·v_{k+1}, x_{k+1}]
(erratum: the paper's text prints 3dt; the Hermite rule is dt/3).
"""

from __future__ import annotations

import torch

from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.kinematics import batch_kinematics, uniform_times
from inkmotion.sigma_lognormal.plan import MotorPlan


def hermite_segments(
    positions: torch.Tensor,  # (N, D)
    velocities: torch.Tensor,  # (N, D)
    counts: torch.Tensor,  # (P,) samples per path block
    dt: torch.Tensor,  # (P,) sample spacing per path
) -> tuple[torch.Tensor, torch.Tensor]:
    """Cubic segments (S, 4, D) joining consecutive samples of each path, and the path
    index (S,) of every segment. S = N − P (no segment crosses a pen lift)."""
    n = positions.shape[0]
    path = torch.repeat_interleave(torch.arange(counts.shape[0], device=counts.device), counts)
    keep = torch.ones(n, dtype=torch.bool, device=positions.device)
    keep[torch.cumsum(counts, 0) - 1] = False  # a block's last sample starts no segment
    a = torch.nonzero(keep).squeeze(1)
    b = a + 1
    h = (dt[path[a]] / 3.0)[:, None]
    seg = torch.stack(
        (positions[a], positions[a] + h * velocities[a], positions[b] - h * velocities[b],
         positions[b]),
        dim=1,
    )
    return seg, path[a]


def batch_bezier_segments(batch: PlanBatch, samples_per_move: int = 5) -> tuple[torch.Tensor,
                                                                                 torch.Tensor]:
    """Segments of every path of a batch on the fitting grid n_p = 5·m_p: ((S, 4, D), (S,))."""
    times, counts, dt = uniform_times(batch, samples_per_move)
    kin = batch_kinematics(batch, times, counts)
    return hermite_segments(kin.positions, kin.velocities, counts, dt)


def bezier_segments(plan: MotorPlan, n: int | None = None) -> torch.Tensor:
    """Cubic Bézier control points (n, 4, D) of ``plan``, n = 5m segments by default."""
    batch = PlanBatch.from_plans([plan])
    if n is None:
        return batch_bezier_segments(batch)[0]
    t_end = batch.end_times()
    dt = t_end / n
    times = torch.arange(n + 1, dtype=dt.dtype, device=dt.device) * dt
    counts = torch.tensor([n + 1], device=times.device)
    kin = batch_kinematics(batch, times, counts)
    return hermite_segments(kin.positions, kin.velocities, counts, dt)[0]
