"""Plots of an evaluation: the speed profiles of the three timings on one time axis
(speeds.png, the paper's Fig. "comparison", middle) and the speed minima colour-coded along
the path (minima.png, the paper's Fig. 3c/d)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: colours of the methods (ΣΛ, minimum jerk, minimum jerk at ΣΛ's passage times,
#: time-optimal), each its own; ΣΛ is drawn over the others but under the minimum jerk at
#: its passage times, dashed, which runs close to it
COLOURS = {"sigma-lognormal": "#222222", "minimum-jerk": "#1f77b4",
           "minimum-jerk-sigma-times": "#2ca02c", "time-optimal": "#d62728"}
LABELS = {"sigma-lognormal": "ΣΛ", "minimum-jerk": "minimum jerk",
          "minimum-jerk-sigma-times": "minimum jerk, ΣΛ's passage times",
          "time-optimal": "time-optimal (TOPP-RA)"}
DASHED = {"minimum-jerk-sigma-times"}


def _speed(position: np.ndarray, dt: float) -> np.ndarray:
    return np.linalg.norm(np.gradient(position[:, :2], dt, axis=0), axis=1)


def plot_speeds(path: str | Path, timed: dict[str, Any], scale: float) -> None:
    """Speed (m/s) against time (s) of every timed path in ``timed`` (name → TimedPath)."""
    from inkmotion.outputs.figure import agg_figure

    fig = agg_figure(8, 3.2)
    ax = fig.add_subplot()
    for name, timed_path in timed.items():
        dt = float(timed_path.t[1] - timed_path.t[0]) if len(timed_path.t) > 1 else 1.0
        ax.plot(timed_path.t, scale * _speed(timed_path.position, dt),
                color=COLOURS.get(name), label=LABELS.get(name, name),
                lw=1.6 if name == "sigma-lognormal" else 1.1,
                ls="--" if name in DASHED else "-",
                zorder=4 if name in DASHED else 3 if name == "sigma-lognormal" else 2)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("speed (m/s)")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"the same path, {len(timed)} timings under the same limits", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)


def plot_minima(path: str | Path, position: np.ndarray, dt: float,
                canvas: tuple[float, float]) -> None:
    """The path (canvas px, y down, cropped to its extent) coloured by the pen's speed
    relative to its peak, with its speed minima as dots (the paper's Fig. 3c/d: the pen
    slows where the path bends). ``canvas`` is only used to keep the y axis pointing down
    in canvas coordinates."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize

    from inkmotion.outputs.figure import agg_figure
    from inkmotion.speed_extrema import find_peaks

    xy = np.asarray(position, dtype=float)[:, :2]
    speed = _speed(xy, dt)
    relative = speed / max(float(speed.max()), 1e-12)
    minima, _ = find_peaks(-speed, prominence=0.02 * max(float(speed.max()), 1e-12))
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = 0.05 * float(max(hi - lo)) + 2.0
    w, h = float(hi[0] - lo[0]) + 2 * pad, float(hi[1] - lo[1]) + 2 * pad
    fig = agg_figure(6.4, min(9.0, 5.4 * h / max(w, 1.0)) + 0.8)
    ax = fig.add_subplot()
    pieces = np.stack([xy[:-1], xy[1:]], axis=1)  # (N−1, 2, 2)
    line = LineCollection(pieces, cmap="viridis", norm=Normalize(0, 1), linewidths=2.2)
    line.set_array(0.5 * (relative[:-1] + relative[1:]))
    ax.add_collection(line)
    ax.scatter(xy[minima, 0], xy[minima, 1], s=30, facecolors="none", edgecolors="#d62728",
               linewidths=1.4, zorder=3, label="speed minimum")
    fig.colorbar(line, ax=ax, label="speed / peak speed", shrink=0.7)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(hi[1] + pad, lo[1] - pad)  # canvas y runs down
    ax.set_aspect("equal")
    ax.set_title(f"{len(minima)} speed minima along the path (canvas "
                 f"{canvas[0]:.0f}×{canvas[1]:.0f} px)", fontsize=9)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_xticks([])
    ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(path)
