"""Hermite → cubic Bézier conversion of sampled trajectories.

Between samples t_k and t_k + dt the segment is
[x_k, x_k + (dt/3)·v_k, x_{k+1} − (dt/3)·v_{k+1}, x_{k+1}]
(erratum: the paper's text prints 3dt; the Hermite rule is dt/3).
"""

from __future__ import annotations

import torch

from inkmotion.scalar_tensors import scalar_tensors
from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch
from inkmotion.sigma_lognormal.kinematics import batch_kinematics, uniform_times
from inkmotion.sigma_lognormal.plan import MotorPlan


def hermite_segments(
    positions: torch.Tensor,  # (N, D)
    velocities: torch.Tensor,  # (N, D)
    layout: GridLayout,
    dt: torch.Tensor,  # (P,) sample spacing per path
) -> torch.Tensor:
    """Cubic segments (S, 4, D) joining consecutive samples of each path; segment s starts
    at sample ``layout.segment_start[s]`` and belongs to path ``layout.segment_path[s]``
    (S = N − P: no segment crosses a pen lift)."""
    a = layout.segment_start  # (S,)
    b = a + 1
    h = (dt.index_select(0, layout.segment_path) / scalar_tensors(dt, 3.0)[0])[:, None]
    # each end gathered once per use: one gather shared by two uses would add the
    # positions' gradients up in another order (other bits, other plans)
    return torch.stack(
        (positions.index_select(0, a),
         positions.index_select(0, a) + h * velocities.index_select(0, a),
         positions.index_select(0, b) - h * velocities.index_select(0, b),
         positions.index_select(0, b)),
        dim=1,
    )


def batch_bezier_segments(batch: PlanBatch, layout: GridLayout | None = None) -> torch.Tensor:
    """Segments (S, 4, D) of every path of a batch on its grid (the fitting grid n_p = 5·m_p
    unless ``layout`` says otherwise)."""
    layout = layout or batch.layout()
    times, dt = uniform_times(batch, layout)
    kin = batch_kinematics(batch, times, layout)
    return hermite_segments(kin.positions, kin.velocities, layout, dt)


def bezier_segments(plan: MotorPlan, n: int | None = None) -> torch.Tensor:
    """Cubic Bézier control points (n, 4, D) of ``plan``, n = 5m segments by default."""
    batch = PlanBatch.from_plans([plan])
    if n is None:
        return batch_bezier_segments(batch)
    counts = torch.full((1,), n + 1, dtype=torch.long, device=batch.moves.device)
    return batch_bezier_segments(batch, batch.layout(counts, n_samples=n + 1))
