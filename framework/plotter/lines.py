"""A plan as polylines in canvas px, for tools that take geometry, not motion (vpype): each
path's exact ΣΛ trajectory over its support, sampled finely enough that no chord is longer
than ``spacing`` px, its creeping ends trimmed (as :mod:`.timing`)."""

from __future__ import annotations

import math

import numpy as np
import torch

from inkmotion.sigma_lognormal.kinematics import kinematics
from inkmotion.sigma_lognormal.plan import Drawing
from inkmotion.sigma_lognormal.support import support

#: at most this many samples per path
MAX_SAMPLES = 200_000


def plan_polylines(drawing: Drawing, spacing: float = 0.25) -> list[np.ndarray]:
    """One polyline (n, 2) px per plan path, chords ≤ ``spacing`` px (plus the sampling's
    own curvature sag, below spacing²·κ/8)."""
    lines = []
    for plan in drawing.plans:
        s = support(plan)
        with torch.no_grad():
            _, v, _ = kinematics(s.plan, torch.as_tensor(s.grid))
        peak = float(torch.linalg.vector_norm(v[:, :2], dim=1).max())
        duration = s.t_b - s.t_a
        n = 1 if peak == 0 else min(MAX_SAMPLES, max(2, math.ceil(duration * peak / spacing)))
        t = torch.linspace(s.t_a, s.t_b, n + 1, dtype=torch.float64)
        with torch.no_grad():
            x = kinematics(s.plan, t)[0][:, :2].numpy()
        keep = [0]
        for j in range(1, len(x)):  # drop samples where the pen creeps (< spacing / 10)
            if np.linalg.norm(x[j] - x[keep[-1]]) >= 0.1 * spacing:
                keep.append(j)
        if keep[-1] != len(x) - 1 and len(keep) > 1:
            keep[-1] = len(x) - 1
        lines.append(x[keep] if len(keep) > 1 else x[[0, 0]])
    return lines
