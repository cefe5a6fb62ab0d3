"""The built-in 'raster' renderer: a differentiable anti-aliased stroke rasterizer in PyTorch.

Each cubic Bézier segment is cut into short straight pieces (chords between uniformly
spaced parameters; the count per segment follows its length and its flatness, computed
from detached values). Every piece is a capsule of radius r = w/2, and a pixel whose
centre lies at distance d from the piece gets the anti-aliased coverage

    c = clamp(r + 1/2 − d, 0, 1)        (ink = 1, paper = 0)

The stroke is the union of its capsules: the image is the per-pixel maximum of c over the
pieces (``scatter_reduce(..., "amax")``), which for a polyline equals the coverage of the
distance to the whole polyline (round joins and round caps). Only a small pixel patch
around each piece is evaluated, so the cost follows the covered pixels, not
pixels × segments. Gradients flow to the control points and to the widths; the device and
dtype follow the inputs.
"""

from __future__ import annotations

import math

import torch

from inkmotion.plugin_host import hookimpl

#: target length (px) of the straight pieces a cubic is cut into
PIECE_LENGTH = 3.0
#: largest distance (px) allowed between a cubic and its chords
FLATNESS = 0.05
#: added under the square root of the distance so its gradient stays finite at d = 0
_EPS = 1e-12


def _check_inputs(
    segments: torch.Tensor, widths: torch.Tensor | float, height: int, width: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """Validate and return control points (S, 4, 2) and widths (S,) in the segments' dtype."""
    if not isinstance(segments, torch.Tensor) or segments.dim() != 3 or segments.shape[1] != 4 \
            or segments.shape[2] not in (2, 3):
        shape = tuple(segments.shape) if isinstance(segments, torch.Tensor) else type(segments)
        raise ValueError(f"Renderer segments must have shape (S, 4, 2) or (S, 4, 3), got {shape}.")
    if not segments.is_floating_point():
        raise ValueError(f"Renderer segments must be floating point, got {segments.dtype}.")
    if int(height) <= 0 or int(width) <= 0:
        raise ValueError(f"Canvas size must be positive, got {height}×{width}.")
    ctrl = segments[..., :2]  # (S, 4, 2); a 3rd (radius) column is ignored
    n_seg = ctrl.shape[0]
    w = torch.as_tensor(widths, dtype=ctrl.dtype, device=ctrl.device)
    if w.dim() == 0:
        w = w.expand(n_seg)
    if w.shape != (n_seg,):
        raise ValueError(f"Widths must be a number or have shape ({n_seg},), got {tuple(w.shape)}.")
    if not bool(torch.isfinite(ctrl).all()):
        raise ValueError("Renderer segments contain NaN or infinite coordinates.")
    if not bool(torch.isfinite(w).all()):
        raise ValueError("Stroke widths contain NaN or infinite values.")
    if bool((w < 0).any()):
        raise ValueError("Stroke widths must be non-negative.")
    return ctrl, w


def piece_counts(ctrl: torch.Tensor, radii: torch.Tensor, height: int, width: int) -> torch.Tensor:
    """Number of straight pieces per segment (S,), detached, 0 for segments off the canvas.

    n = max(⌈|control polygon| / PIECE_LENGTH⌉, ⌈√(0.75·M / FLATNESS)⌉, 1), with
    M = max(|P0 − 2P1 + P2|, |P1 − 2P2 + P3|): the chord error of n uniform pieces is at most
    max|B''| / (8n²) ≤ 6M / (8n²). A segment whose control hull, grown by r + 1, misses the
    canvas gets 0 (the curve lies inside its control hull).
    """
    with torch.no_grad():
        legs = ctrl[:, 1:] - ctrl[:, :-1]  # (S, 3, 2)
        poly = legs.norm(dim=-1).sum(-1)  # (S,)
        bend = (legs[:, 1:] - legs[:, :-1]).norm(dim=-1).amax(-1)  # (S,)
        n = torch.maximum(torch.ceil(poly / PIECE_LENGTH),
                          torch.ceil(torch.sqrt(0.75 * bend / FLATNESS))).clamp(min=1)
        cap = math.ceil(4 * (height + width) / PIECE_LENGTH) + 4  # bounds memory on wild input
        n = n.clamp(max=cap).long()
        grow = (radii + 1)[:, None]  # (S, 1)
        lo, hi = ctrl.amin(1) - grow, ctrl.amax(1) + grow  # (S, 2)
        inside = (hi[:, 0] > 0) & (hi[:, 1] > 0) & (lo[:, 0] < width) & (lo[:, 1] < height)
        return n * inside


def flatten(ctrl: torch.Tensor, counts: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor,
                                                                  torch.Tensor]:
    """Chop each cubic into ``counts[s]`` chords between the parameters u = k / counts[s].

    B(u) = (1−u)³P0 + 3u(1−u)²P1 + 3u²(1−u)P2 + u³P3. Returns the pieces' start points
    (N, 2), end points (N, 2) and segment index (N,), N = Σ counts; differentiable in ctrl.
    """
    n_seg, dev = ctrl.shape[0], ctrl.device
    seg_ids = torch.arange(n_seg, device=dev)
    npts = counts + (counts > 0)  # (S,) points per segment: n + 1, or 0 when culled
    point_seg = torch.repeat_interleave(seg_ids, npts)  # (P,)
    first = torch.cumsum(npts, 0) - npts  # (S,) index of each segment's first point
    k = torch.arange(point_seg.shape[0], device=dev) - first[point_seg]  # (P,)
    u = (k.to(ctrl.dtype) / counts[point_seg].to(ctrl.dtype))[:, None]  # (P, 1)
    v = 1 - u
    basis = torch.cat((v * v * v, 3 * u * v * v, 3 * u * u * v, u * u * u), 1)  # (P, 4)
    pts = torch.einsum("pk,pkd->pd", basis, ctrl[point_seg])  # (P, 2)
    piece_seg = torch.repeat_interleave(seg_ids, counts)  # (N,)
    # piece j of segment s starts at point first[s] + (j − Σ_{s'<s} counts[s']) = j + (#segments
    # before s that have points); with culled segments that is j + rank of s among kept ones
    kept_rank = torch.cumsum(counts > 0, 0) - 1  # (S,)
    start = torch.arange(piece_seg.shape[0], device=dev) + kept_rank[piece_seg]  # (N,)
    return pts[start], pts[start + 1], piece_seg


def render_segments(
    segments: torch.Tensor, widths: torch.Tensor | float, height: int, width: int
) -> torch.Tensor:
    """Render cubic Bézier segments (S, 4, 2) in pixel coordinates (x right, y down; pixel
    (r, c) centred at (c + ½, r + ½)) with stroke widths (S,) or a number to a coverage image
    (H, W) in [0, 1]: I(p) = max over pieces of clamp(w/2 + ½ − dist(p, piece), 0, 1).

    Differentiable w.r.t. segments and widths. Raises ValueError on NaN/inf input or bad
    shapes. A 3rd (radius) coordinate, if present, is ignored.
    """
    height, width = int(height), int(width)
    ctrl, w = _check_inputs(segments, widths, height, width)
    dtype, dev = ctrl.dtype, ctrl.device
    img = torch.zeros(height * width, dtype=dtype, device=dev)
    radii = w / 2  # (S,)
    counts = piece_counts(ctrl, radii.detach(), height, width)  # (S,)
    if ctrl.shape[0] == 0 or int(counts.sum()) == 0:
        return img.reshape(height, width) + 0 * (ctrl.sum() + w.sum())  # keeps the graph
    a, b, piece_seg = flatten(ctrl, counts)  # (N, 2), (N, 2), (N,)
    r = radii[piece_seg]  # (N,)

    with torch.no_grad():  # pixel range of each piece: centres within r + ½ of it, on canvas
        reach = (r + 0.5)[:, None]  # (N, 1)
        lo = torch.minimum(a, b) - reach  # (N, 2)
        hi = torch.maximum(a, b) + reach
        c0 = (torch.floor(lo - 0.5) + 1).clamp(min=0).long()  # first centre > lo
        size = torch.tensor([width - 1, height - 1], device=dev)
        c1 = torch.minimum((torch.ceil(hi - 0.5) - 1).long(), size)  # last centre < hi
        keep = (c1 >= c0).all(1)  # (N,) pieces that touch the canvas
    if not bool(keep.all()):
        a, b, r, c0, c1 = a[keep], b[keep], r[keep], c0[keep], c1[keep]
    if a.shape[0] == 0:
        return img.reshape(height, width) + 0 * (ctrl.sum() + w.sum())

    with torch.no_grad():
        kx, ky = (c1 - c0 + 1).amax(0).tolist()  # patch size: the widest piece range
        xs = c0[:, :1] + torch.arange(kx, device=dev)  # (N, kx) pixel columns
        ys = c0[:, 1:] + torch.arange(ky, device=dev)  # (N, ky) pixel rows
        valid = (ys <= c1[:, 1:])[:, :, None] & (xs <= c1[:, :1])[:, None, :]  # (N, ky, kx)
        flat = ys.minimum(c1[:, 1:])[:, :, None] * width + xs.minimum(c1[:, :1])[:, None, :]

    # capsule distance: t = clamp(ap·ab / |ab|², 0, 1), d = |ap − t·ab|
    ab = b - a  # (N, 2)
    inv_len2 = 1 / (ab * ab).sum(1).clamp(min=1e-12)  # (N,)
    dx = (xs.to(dtype) + 0.5 - a[:, :1])[:, None, :]  # (N, 1, kx)
    dy = (ys.to(dtype) + 0.5 - a[:, 1:])[:, :, None]  # (N, ky, 1)
    abx, aby = ab[:, 0, None, None], ab[:, 1, None, None]  # (N, 1, 1)
    t = ((dx * abx + dy * aby) * inv_len2[:, None, None]).clamp(0, 1)  # (N, ky, kx)
    ex, ey = dx - t * abx, dy - t * aby
    d = torch.sqrt(ex * ex + ey * ey + _EPS)  # (N, ky, kx)
    cov = (r[:, None, None] + 0.5 - d).clamp(0, 1) * valid  # (N, ky, kx)
    img = img.scatter_reduce(0, flat.reshape(-1), cov.reshape(-1), reduce="amax",
                             include_self=True)
    return img.reshape(height, width)


class RasterRenderer:
    """The 'raster' renderer plugin object (see :func:`render_segments`)."""

    name = "raster"
    description = "Differentiable anti-aliased stroke rasterizer (plain PyTorch, CPU and CUDA)."

    def __call__(
        self, segments: torch.Tensor, widths: torch.Tensor | float, height: int, width: int
    ) -> torch.Tensor:
        """Coverage image (H, W) in [0, 1] of cubic segments (S, 4, 2) with widths (S,)."""
        return render_segments(segments, widths, height, width)


@hookimpl
def inkmotion_renderers() -> list:
    """The built-in renderers of this module."""
    return [RasterRenderer()]
