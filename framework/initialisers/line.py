"""A start trajectory for a tag with no input trace: a horizontal zig-zag across the canvas.

The paper's CLIP-guided tag generation starts from "an initial trajectory with Δt = 1"
(Fig. 4a, left) and does not give its shape in the text. Here its targets alternate above
and below the canvas's horizontal centre line, along the line a word is written on,

    p_k = (c_x − L/2 + k·L/m,  c_y + (−1)^k · A),   k = 0..m,

with L = ``extent`` × canvas width and A = ``amplitude`` × canvas height (y down: p_0 lies
below the centre line and the first stroke goes up). A straight line (A = 0) is a poor
start: its sub-movements are collinear, so the ΣΛ trajectory is one straight segment with
no turn for δ to act on, and CLIP's gradient on a thin horizontal line is weak. The
zig-zag gives every sub-movement a vertical component — the up- and down-strokes letters
are made of — and a corner at every target. The default m = 30 is the size of real tag
plans: the two Graffiti Analysis tags simplified at the authors' DCE threshold have 29 and
36 targets (350-px canvas). A = 5 % of the height gives steep strokes, 35 px tall at a
350-px canvas with the targets 9.3 px apart: a band of up- and down-strokes, a third of a
letter's height, that the optimiser can stretch without first having to create them.
"""

from __future__ import annotations

import numpy as np

#: sub-movements (the size of real tag plans, module docstring)
DEFAULT_TARGETS = 30
#: fraction of the canvas width the zig-zag spans
DEFAULT_EXTENT = 0.8
#: half height of the zig-zag as a fraction of the canvas height
DEFAULT_AMPLITUDE = 0.05


def zigzag(canvas: tuple[float, float], targets: int = DEFAULT_TARGETS,
           extent: float = DEFAULT_EXTENT, amplitude: float = DEFAULT_AMPLITUDE) -> np.ndarray:
    """Targets (targets + 1, 2) px of a zig-zag centred on ``canvas`` (W, H) (module
    docstring); inside the canvas for extent ≤ 1 and amplitude ≤ ½."""
    w, h = float(canvas[0]), float(canvas[1])
    k = np.arange(targets + 1, dtype=np.float64)
    length = extent * w
    x = w / 2 - length / 2 + k * length / targets
    y = h / 2 + np.where(k % 2 == 0, 1.0, -1.0) * amplitude * h
    return np.column_stack((x, y))
