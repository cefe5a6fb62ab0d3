"""Plots of an evaluation: the speed profiles of the three timings on one time axis
(speeds.png, the paper's Fig. "comparison", middle) and the speed minima colour-coded along
the path (minima.png, the paper's Fig. 3c/d)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: colours of the methods (ΣΛ, minimum jerk, time-optimal)
COLOURS = {"sigma-lognormal": "#222222", "minimum-jerk": "#1f77b4", "time-optimal": "#d62728"}
LABELS = {"sigma-lognormal": "ΣΛ", "minimum-jerk": "minimum jerk",
          "time-optimal": "time-optimal (TOPP-RA)"}


def _speed(position: np.ndarray, dt: float) -> np.ndarray:
    return np.linalg.norm(np.gradient(position[:, :2], dt, axis=0), axis=1)


def plot_speeds(path: str | Path, timed: dict[str, Any], scale: float) -> None:
    """Speed (m/s) against time (s) of every timed path in ``timed`` (name → TimedPath)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=120)
    for name, timed_path in timed.items():
        dt = float(timed_path.t[1] - timed_path.t[0]) if len(timed_path.t) > 1 else 1.0
        ax.plot(timed_path.t, scale * _speed(timed_path.position, dt),
                color=COLOURS.get(name), label=LABELS.get(name, name), lw=1.2)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("speed (m/s)")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("the same path, three timings under the same limits", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_minima(path: str | Path, position: np.ndarray, dt: float,
                canvas: tuple[float, float]) -> None:
    """The path (grey, canvas px, y down) with its speed minima as dots coloured by how
    slow the pen is there, relative to the peak speed (dark: nearly stopped)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.signal import find_peaks

    speed = _speed(position, dt)
    minima, _ = find_peaks(-speed, prominence=0.02 * max(float(speed.max()), 1e-12))
    w, h = float(canvas[0]), float(canvas[1])
    fig, ax = plt.subplots(figsize=(6, 6 * h / max(w, 1.0) + 0.6), dpi=120)
    ax.plot(position[:, 0], position[:, 1], color="#bbbbbb", lw=1.5)
    dots = ax.scatter(position[minima, 0], position[minima, 1],
                      c=speed[minima] / max(float(speed.max()), 1e-12), cmap="viridis",
                      vmin=0, vmax=1, s=22, zorder=3)
    fig.colorbar(dots, ax=ax, label="speed at the minimum / peak speed", shrink=0.7)
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal")
    ax.set_title(f"{len(minima)} speed minima along the path", fontsize=9)
    ax.axis("off")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
