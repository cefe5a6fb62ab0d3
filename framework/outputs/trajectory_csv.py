"""trajectory.csv: kinematics of every trajectory sampled uniformly in time.

Columns ``path,t,x,y,[r,]vx,vy,ax,ay,speed`` (r, the radius in px, only for 3-D plans):
path p is sampled at t_k = k·T_end/n, k = 0..n with n = samples_per_move·m_p, t in s
from the path's own start; positions in px, velocities px/s, accelerations px/s²,
speed = |(vx, vy)|.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from inkmotion.outputs.sampling import sample
from inkmotion.sigma_lognormal.plan import MotorPlan


def _fmt(v: float) -> str:
    return f"{v:.9g}"


def write_trajectory_csv(
    path: str | Path, plans: list[MotorPlan], samples_per_move: int = 20
) -> None:
    """Write the sampled kinematics of ``plans`` (one block of rows per path)."""
    assert plans and samples_per_move >= 1
    dims = {p.dim for p in plans}
    assert len(dims) == 1, f"plans mix 2-D and 3-D points: {dims}"
    three = dims.pop() == 3
    header = ["path", "t", "x", "y"] + (["r"] if three else []) + [
        "vx", "vy", "ax", "ay", "speed"]
    with open(path, "w", newline="", encoding="utf-8") as f:
        out = csv.writer(f)
        out.writerow(header)
        for k, plan in enumerate(plans):
            s = sample(plan, samples_per_move)
            cols = np.column_stack((s.t, s.positions, s.velocities[:, :2],
                                    s.accelerations[:, :2], s.speed)).tolist()
            out.writerows([str(k), *map(_fmt, row)] for row in cols)
