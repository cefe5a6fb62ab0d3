"""A matplotlib figure of the caller's own: a ``Figure`` on the Agg canvas.

Nothing global changes (no ``matplotlib.use``, no pyplot figure left open to close), so a
plot written from a notebook, a worker or a test leaves the process's backend and figures
as they were; and it skips pyplot's import and figure bookkeeping.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def agg_figure(width: float, height: float, dpi: int = 120) -> Figure:
    """A figure of ``width`` × ``height`` inches at ``dpi``, drawn by Agg (``savefig``)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=dpi)
    FigureCanvasAgg(fig)
    return fig
