"""Pictures of a plot: plot_preview.png (the paper, each segment coloured by its feed,
pen-up travel dashed) and feed.png (the feed of every segment against the ΣΛ speed it
stands for, over machine time), so a user sees the motion before the machine moves."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from inkmotion.plotter.timing import PlotStroke


def write_preview(path: Path, strokes: list[PlotStroke], paper: tuple[float, float],
                  title: str) -> None:
    """plot_preview.png (module docstring)."""
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Rectangle

    from inkmotion.outputs.figure import agg_figure

    w, h = paper
    fig = agg_figure(6.0 * w / max(w, h) + 1.2, 6.0 * h / max(w, h) + 0.6, dpi=150)
    ax = fig.add_subplot()
    ax.add_patch(Rectangle((0, 0), w, h, fill=False, lw=0.8, color="0.4"))
    segments = [np.stack((st.points[:-1], st.points[1:]), axis=1) for st in strokes
                if len(st.points) > 1]
    feeds = np.concatenate([st.feeds for st in strokes if len(st.points) > 1] or [[0.0]])
    if segments:
        lines = LineCollection(np.concatenate(segments), array=feeds, cmap="viridis",
                               linewidths=1.2)
        ax.add_collection(lines)
        fig.colorbar(lines, ax=ax, fraction=0.04, pad=0.02, label="feed (mm/s)")
    here = np.zeros(2)
    for st in strokes:
        ax.plot([here[0], st.points[0, 0]], [here[1], st.points[0, 1]], ls="--", lw=0.5,
                color="tab:red", alpha=0.6)
        if len(st.points) == 1:
            ax.plot(*st.points[0], "o", ms=2, color="black")
        here = st.points[-1]
    ax.plot([here[0], 0], [here[1], 0], ls="--", lw=0.5, color="tab:red", alpha=0.6)
    ax.set_xlim(-0.02 * w, 1.02 * w)
    ax.set_ylim(-0.02 * h, 1.02 * h)
    ax.set_aspect("equal")
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    ax.set_title(title, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, bbox_inches="tight", pad_inches=0.1)  # an equal-aspect portrait
    # sheet leaves the axes narrower than tight_layout plans for: the Y label was cut


def write_feed_plot(path: Path, strokes: list[PlotStroke]) -> None:
    """feed.png: per-segment feed (steps) and the ΣΛ speed (line), stroke after stroke."""
    from inkmotion.outputs.figure import agg_figure

    fig = agg_figure(9, 3)
    ax = fig.add_subplot()
    t0 = 0.0
    for i, st in enumerate(strokes):
        if len(st.durations) == 0:
            continue
        t = t0 + np.concatenate([[0.0], np.cumsum(st.durations)])
        ax.stairs(st.feeds, t, color="tab:blue", lw=0.8, label="G1 feed" if i == 0 else None)
        mid = 0.5 * (t[:-1] + t[1:])
        ax.plot(mid, st.plan_speed, color="tab:orange", lw=0.8,
                label="ΣΛ speed (time-scaled)" if i == 0 else None)
        t0 = t[-1] + 0.1
    ax.set_xlabel("drawing time (s, pen-up time left out)")
    ax.set_ylabel("mm/s")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
