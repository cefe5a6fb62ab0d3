"""speed.png: speed profiles like the paper's Fig. 2c.

The total speed |v(t)| of each trajectory is drawn in black and the contribution
Λ_i(t)·h_i·|d_i| of each lognormal as a thin blue line; trajectories are laid one after
another on the time axis, separated by a small gap (pen lift), with a faint band marking
each. Matplotlib is used through its object API (:func:`~inkmotion.outputs.figure.agg_figure`),
so no global backend state is changed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from inkmotion.outputs.sampling import on_cpu
from inkmotion.sigma_lognormal.plan import MotorPlan
from inkmotion.sigma_lognormal.speed import speed_profile

SAMPLES_PER_MOVE = 25
MIN_SAMPLES = 200


def write_speed_plot(path: str | Path, plans: list[MotorPlan]) -> None:
    """Write the speed profiles of ``plans`` (time in s, speed in px/s) to an image file."""
    from matplotlib.collections import LineCollection

    from inkmotion.outputs.figure import agg_figure

    assert plans, "at least one plan"
    plans = [on_cpu(p) for p in plans]
    ends = [float(p.end_time) for p in plans]
    gap = 0.03 * sum(ends) + 1e-3
    fig = agg_figure(10, 3.2)
    ax = fig.add_subplot(1, 1, 1)
    bells: list[np.ndarray] = []
    start = 0.0
    top = 0.0
    for k, (plan, t_end) in enumerate(zip(plans, ends, strict=True)):
        n = max(MIN_SAMPLES, SAMPLES_PER_MOVE * plan.m)
        with torch.no_grad():
            t = torch.linspace(0.0, t_end, n, dtype=torch.float64)
            total, parts = speed_profile(on_cpu(plan, torch.float64), t)
        x = start + t.numpy()
        total, parts = total.numpy(), parts.numpy()  # (n,), (m, n)
        top = max(top, float(total.max(initial=0.0)), float(parts.max(initial=0.0)))
        for row in parts:
            on = row > 1e-4 * max(float(row.max()), 1e-12)  # draw the bell's support only
            if on.any():
                i, j = np.argmax(on), len(on) - np.argmax(on[::-1])
                bells.append(np.column_stack((x[i:j], row[i:j])))
        ax.plot(x, total, color="black", linewidth=1.2, zorder=3)
        if k % 2 == 1:
            ax.axvspan(start, start + t_end, color="0.94", zorder=0, linewidth=0)
        start += t_end + gap
    ax.add_collection(LineCollection(bells, colors="tab:blue", linewidths=0.6, zorder=4))
    ax.set_xlim(0.0, max(start - gap, 1e-3))
    ax.set_ylim(0.0, 1.05 * top if top > 0 else 1.0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("speed (px/s)")
    ax.set_title(f"{len(plans)} path(s), {sum(p.m for p in plans)} lognormals", fontsize=9)
    fig.tight_layout()
    fig.savefig(str(path))
