"""speed.png: speed profiles like the paper's Fig. 2c.

The total speed |v(t)| of each trajectory is drawn in black and the contribution
Λ_i(t)·h_i·|d_i| of each lognormal as a thin blue line; trajectories are laid one after
another on the time axis, separated by a small gap (pen lift), with a faint band marking
every other one. Drawn with OpenCV (:class:`~inkmotion.outputs.chart.Chart`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import torch

from inkmotion.outputs.chart import BOLD, THIN, Chart
from inkmotion.outputs.sampling import on_cpu
from inkmotion.sigma_lognormal.plan import MotorPlan
from inkmotion.sigma_lognormal.speed import speed_profile

SAMPLES_PER_MOVE = 25
MIN_SAMPLES = 200
#: the image's width × height, px
SIZE = (1200, 384)
TOTAL_RGB = (0, 0, 0)
PART_RGB = (31, 119, 180)
#: the speed axis runs this much above the highest peak
HEADROOM = 1.05


def _profiles(plans: list[MotorPlan]) -> tuple[list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                                               list[float]]:
    """Per plan (float64, on the CPU): times (n,) on the shared axis, total speed (n,),
    each move's (m, n); and the plans' starts on that axis, then where the last one ends."""
    ends = [float(p.end_time) for p in plans]
    gap = 0.03 * sum(ends) + 1e-3
    curves, starts = [], []
    start = 0.0
    for plan, t_end in zip(plans, ends, strict=True):
        n = max(MIN_SAMPLES, SAMPLES_PER_MOVE * plan.m)
        with torch.no_grad():
            t = torch.linspace(0.0, t_end, n, dtype=torch.float64)
            total, parts = speed_profile(plan, t)
        curves.append((start + t.numpy(), total.numpy(), parts.numpy()))
        starts.append(start)
        start += t_end + gap
    return curves, [*starts, start - gap]


def _bell(x: np.ndarray, row: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """One move's speed over its support only (where it is above 10⁻⁴ of its peak)."""
    on = row > 1e-4 * max(float(row.max(initial=0.0)), 1e-12)
    if not on.any():
        return None
    i, j = int(np.argmax(on)), len(on) - int(np.argmax(on[::-1]))
    return x[i:j], row[i:j]


def write_speed_plot(path: str | Path, plans: list[MotorPlan]) -> None:
    """Write the speed profiles of ``plans`` (time in s, speed in px/s) to an image file."""
    assert plans, "at least one plan"
    plans = [on_cpu(p, torch.float64) for p in plans]
    curves, starts = _profiles(plans)
    top = max(float(np.max(v, initial=0.0, where=np.isfinite(v)))
              for _, total, parts in curves for v in (total, parts))
    top = top if top > 0 else 1.0 / HEADROOM
    x_max = starts[-1] if math.isfinite(starts[-1]) and starts[-1] > 1e-3 else 1e-3
    chart = Chart(SIZE, x_max, HEADROOM * top, y_ticks_to=top,
                  title=f"{len(plans)} path(s), {sum(p.m for p in plans)} lognormals",
                  x_label="time (s)", y_label="speed (px/s)")
    for k in range(1, len(plans), 2):
        chart.band(starts[k], starts[k] + float(plans[k].end_time))
    chart.lines([(x, total) for x, total, _ in curves], TOTAL_RGB, BOLD)
    chart.lines([bell for x, _, parts in curves for row in parts
                 if (bell := _bell(x, row)) is not None], PART_RGB, THIN)
    chart.write(path)
