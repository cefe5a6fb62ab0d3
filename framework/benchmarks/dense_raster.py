"""The raster benchmark's baseline: a dense stroke rasterizer written for this project.

It draws the same image as the 'raster' renderer (:mod:`inkmotion.rendering.raster`) the
obvious way: the cubic segments are cut into the same straight pieces (the renderer's own
:func:`~inkmotion.rendering.raster.piece_counts` and
:func:`~inkmotion.rendering.raster.flatten`), and then every piece is measured against
every pixel of the canvas — no tiles, no patches, no culling:

    I(p) = max over pieces k of clamp(r_k + ½ − d_k(p), 0, 1)

with d_k(p) the distance of pixel centre p to piece k. The search over all pieces runs
without autograd, in chunks of :data:`CHUNK` pieces (memory: one chunk × the canvas), and
keeps each pixel's best piece; the image is then that piece's coverage, computed again
with autograd: the same value as the maximum and the same gradient (a maximum passes its
gradient to its arg max). The cost is pieces × pixels, where the renderer's is the pixels
near each piece, so the ratio of the two times says what the renderer's patches buy.
Constant width only (segments (S, 4, 2) and widths (S,)).
"""

from __future__ import annotations

import torch

from inkmotion.rendering.raster import flatten, piece_counts

#: pieces measured against the whole canvas at once
CHUNK = 64


def _coverage(a: torch.Tensor, b: torch.Tensor, r: torch.Tensor, px: torch.Tensor,
              py: torch.Tensor) -> torch.Tensor:
    """clamp(r + ½ − d, 0, 1) of pixel centres (px, py) against pieces a → b with radii r,
    all broadcast together (e.g. (c, 1) pieces against (1, H·W) pixels)."""
    abx, aby = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    dx, dy = px - a[..., 0], py - a[..., 1]
    t = ((dx * abx + dy * aby) / (abx * abx + aby * aby).clamp(min=1e-12)).clamp(0, 1)
    ex, ey = dx - t * abx, dy - t * aby
    return (r + 0.5 - torch.sqrt(ex * ex + ey * ey + 1e-12)).clamp(0, 1)


def nearest_pieces(a: torch.Tensor, b: torch.Tensor, r: torch.Tensor, px: torch.Tensor,
                   py: torch.Tensor) -> torch.Tensor:
    """For every pixel (H·W,) the piece of largest coverage (ties: the first), measuring
    every piece (N,) against every pixel, a chunk of pieces at a time; no autograd."""
    with torch.no_grad():
        best = torch.full_like(px, -1.0)  # coverage ≥ 0, so any piece beats it
        index = torch.zeros(px.shape, dtype=torch.long, device=px.device)
        for start in range(0, a.shape[0], CHUNK):
            stop = min(start + CHUNK, a.shape[0])
            cov = _coverage(a[start:stop, None], b[start:stop, None], r[start:stop, None],
                            px[None], py[None])  # (c, H·W)
            value, k = cov.max(0)
            better = value > best
            best = torch.where(better, value, best)
            index = torch.where(better, k + start, index)
    return index


def render_dense(segments: torch.Tensor, widths: torch.Tensor, height: int,
                 width: int) -> torch.Tensor:
    """Coverage image (H, W) of cubic segments (S, 4, 2) px with stroke widths (S,) px,
    every piece against every pixel (module docstring); differentiable in both."""
    radii = widths / 2  # (S,)
    counts = piece_counts(segments, radii, height, width)
    a, b, piece_seg = flatten(segments, counts)  # (N, 2), (N, 2), (N,)
    r = radii[piece_seg]  # (N,)
    dtype, dev = segments.dtype, segments.device
    ys, xs = torch.meshgrid(torch.arange(height, dtype=dtype, device=dev) + 0.5,
                            torch.arange(width, dtype=dtype, device=dev) + 0.5, indexing="ij")
    px, py = xs.reshape(-1), ys.reshape(-1)  # (H·W,)
    if a.shape[0] == 0:
        return segments.new_zeros(height, width) + 0 * (segments.sum() + widths.sum())
    k = nearest_pieces(a, b, r, px, py)  # (H·W,)
    return _coverage(a[k], b[k], r[k], px, py).reshape(height, width)
