"""A whole drawing through a renderer, outside the optimisation (no gradient): the one
place that turns motor plans or input polylines into a coverage image.

The renderer is any object of the renderer protocol
(:class:`inkmotion.plugin_host.protocols.Renderer`): the caller looks it up (a job's
``--renderer``, or the built-in 'raster'); this engine never asks the plugin host. Every
segment goes to one renderer call, so the image is the renderer's union of all strokes
(for 'raster' the per-pixel maximum, the same as drawing each path alone and taking the
maximum).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import Renderer
    from inkmotion.sigma_lognormal.plan import MotorPlan


def render_plans(renderer: Renderer, plans: Sequence[MotorPlan], canvas: tuple[int, int],
                 scale: float = 1.0, dtype: torch.dtype | None = None) -> torch.Tensor:
    """Coverage (H, W) of ``plans`` on a ``canvas`` (width, height) px of the output, the
    strokes and their widths scaled by ``scale`` from the plans' canvas (a 3-D plan's
    radius is a coordinate and scales with it), in ``dtype`` (None: the plans')."""
    segments, widths = plan_segments(plans, scale, dtype)
    with torch.no_grad():
        return renderer(segments, widths, int(canvas[1]), int(canvas[0]))


def plan_segments(plans: Sequence[MotorPlan], scale: float = 1.0,
                  dtype: torch.dtype | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """The Bézier segments (S, 4, D) of every plan, detached, scaled by ``scale`` (a 3-D
    plan's radius with them) in ``dtype`` (None: the plans'), and each segment's pen width
    (S,) scaled the same: what a renderer draws (:func:`render_plans`)."""
    from inkmotion.geometry.bezier import bezier_segments

    with torch.no_grad():
        segments = [bezier_segments(plan).detach() for plan in plans]
        if dtype is not None:
            segments = [s.to(dtype) for s in segments]
        if scale != 1.0:
            segments = [s * scale for s in segments]
        widths = torch.cat([torch.full((s.shape[0],), plan.width * scale, dtype=s.dtype,
                                       device=s.device)
                            for s, plan in zip(segments, plans, strict=True)])
        return torch.cat(segments), widths


def polyline_segments(strokes: Sequence[np.ndarray], dtype: torch.dtype,
                      device: Any) -> torch.Tensor:
    """Input polylines (canvas px, x and y first) as straight cubic segments (S, 4, 2),
    control points at thirds of each edge."""
    parts = []
    for s in strokes:
        pts = torch.as_tensor(np.asarray(s)[:, :2], dtype=dtype, device=device)
        a, b = pts[:-1], pts[1:]
        parts.append(torch.stack((a, a + (b - a) / 3, a + 2 * (b - a) / 3, b), dim=1))
    return torch.cat(parts)


def render_polylines(renderer: Renderer, strokes: Sequence[np.ndarray], width: float,
                     canvas: tuple[int, int], dtype: torch.dtype = torch.float32,
                     device: Any = "cpu") -> torch.Tensor:
    """Coverage (H, W) of the input polylines drawn ``width`` px wide: the target image a
    fit is compared with."""
    with torch.no_grad():
        segments = polyline_segments(strokes, dtype, device)
        widths = torch.full((len(segments),), width, dtype=dtype, device=device)
        return renderer(segments, widths, int(canvas[1]), int(canvas[0]))
