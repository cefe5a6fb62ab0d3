"""A differentiable anti-aliased stroke rasterizer in plain PyTorch (the 'raster' renderer).

Each cubic Bézier segment is cut into short straight pieces (chords between uniformly
spaced parameters; the count per segment follows its length and its flatness, computed
from detached values). Every piece is a capsule of radius r, and a pixel whose centre lies
at distance d from the piece gets the anti-aliased coverage

    c = clamp(r + 1/2 − d, 0, 1)        (ink = 1, paper = 0)

The stroke is the union of its capsules: the image is the per-pixel maximum of c over the
pieces (``scatter_reduce(..., "amax")``), which for a polyline equals the coverage of the
distance to the whole polyline (round joins and round caps). Only a small pixel patch
around each piece is evaluated, so the cost follows the covered pixels, not
pixels × segments. The device and dtype follow the inputs.

Segments are (S, 4, 2) with widths (S,): r = w/2 for every piece of segment s; or
(S, 4, 3), the third coordinate being the stroke radius in px (the 2.5D plans of
2.5D plans; widths are then ignored). There the radius is a cubic in u like x and y,
evaluated with them at the piece's two ends (r_a, r_b, clamped at 0), and interpolated
along the piece at the pixel's projection t:

    r(t) = r_a + t·(r_b − r_a),         c = clamp(r(t) + 1/2 − d, 0, 1)

so the width changes continuously (consecutive pieces meet with the same radius, no
steps every 3 px) at the cost of one multiply-add per evaluated pixel. Gradients flow to
the control points and to the widths, or to the radius coordinate.

Two paths compute the same image:

- :func:`render_segments` sizes everything from the data (the number of pieces, the patch
  around a piece): a few reads of the device per call, free on a CPU.
- :func:`render_segments_static` uses a :class:`RasterBudget` planned once
  (:func:`plan_budget`) with headroom, so its shapes are static and it never reads the
  device (static shapes for accelerators). When the data outgrow the budget it still draws, coarser
  (fewer pieces) or clipped (smaller patches), and raises a flag on the device;
  :class:`RasterSession` keeps the budget and replans when asked after the flag was set.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from typing import Any

import torch

from inkmotion.portable_math import planar_norm
from inkmotion.scalar_tensors import scalar_tensors

#: target length (px) of the straight pieces a cubic is cut into
PIECE_LENGTH = 3.0
#: largest distance (px) allowed between a cubic and its chords
FLATNESS = 0.05
#: added under the square root of the distance so its gradient stays finite at d = 0
_EPS = 1e-12
#: budget headroom: pieces planned = HEADROOM × pieces seen (+ one per segment)
HEADROOM = 1.5
#: extra pixels of a planned patch side over the widest piece seen
PATCH_MARGIN = 2
#: a budget's flag is raised past this fraction of its pieces, or when a piece's pixel
#: range reaches its patch side, before anything is coarsened or clipped
ALARM = 0.85


@dataclass(frozen=True)
class RasterBudget:
    """Static sizes of :func:`render_segments_static`: pieces in all, and the pixel patch
    (columns, rows) evaluated around each piece."""

    pieces: int
    patch_x: int
    patch_y: int


@dataclass(frozen=True)
class Canvases:
    """Several drawings rendered by one call (a batched fit): segment s goes to image
    ``image[s]``, and image b is ``sizes[b]`` = (width, height) px, drawn into the top-left
    corner of a (count, H, W) stack whose H, W are the call's (at least the largest). A
    piece is clipped to its own canvas, so no drawing bleeds into another."""

    image: torch.Tensor  # (S,) long
    sizes: torch.Tensor  # (count, 2) long: (width, height)
    count: int


# --- validation and sizes (detached) ---------------------------------------------------------
def check_inputs(
    segments: torch.Tensor, widths: torch.Tensor | float, height: int, width: int,
    check: bool = True,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Control points (S, 4, D) and widths (S,) in the segments' dtype, after checking the
    shapes (Python-level, free). With ``check`` also the values (NaN, inf, negative widths
    or, for D = 3, negative radii), which reads the device: a fitting loop passes
    ``check=False`` and checks its loss. For D = 3 the widths' values are ignored."""
    if not isinstance(segments, torch.Tensor) or segments.dim() != 3 or segments.shape[1] != 4 \
            or segments.shape[2] not in (2, 3):
        shape = tuple(segments.shape) if isinstance(segments, torch.Tensor) else type(segments)
        raise ValueError(f"Renderer segments must have shape (S, 4, 2) or (S, 4, 3), got {shape}.")
    if not segments.is_floating_point():
        raise ValueError(f"Renderer segments must be floating point, got {segments.dtype}.")
    if int(height) <= 0 or int(width) <= 0:
        raise ValueError(f"Canvas size must be positive, got {height}×{width}.")
    ctrl = segments  # (S, 4, D): x, y[, r]
    n_seg = ctrl.shape[0]
    if isinstance(widths, torch.Tensor):
        w = widths.to(dtype=ctrl.dtype, device=ctrl.device)
    else:
        w = torch.full((), float(widths), dtype=ctrl.dtype, device=ctrl.device)
    if w.dim() == 0:
        w = w.expand(n_seg)
    if w.shape != (n_seg,):
        raise ValueError(f"Widths must be a number or have shape ({n_seg},), got {tuple(w.shape)}.")
    if check:
        if not bool(torch.isfinite(ctrl).all()):
            raise ValueError("Renderer segments contain NaN or infinite coordinates.")
        if _varying(ctrl):
            if bool((ctrl[..., 2] < 0).any()):
                raise ValueError("Stroke radii (the segments' 3rd coordinate) must be "
                                 "non-negative.")
        elif not bool(torch.isfinite(w).all()):
            raise ValueError("Stroke widths contain NaN or infinite values.")
        elif bool((w < 0).any()):
            raise ValueError("Stroke widths must be non-negative.")
    return ctrl, w


def _varying(ctrl: torch.Tensor) -> bool:
    """Whether the segments (S, 4, D) carry their own radius (D = 3): a shape, no read."""
    return ctrl.shape[-1] == 3


def segment_radii(ctrl: torch.Tensor, w: torch.Tensor) -> torch.Tensor:
    """Largest radius of each segment (S,): w/2, or for D = 3 the largest control radius
    clamped at 0 (a cubic lies in the hull of its control values, so r(u) ≤ max r_k)."""
    if _varying(ctrl):
        return ctrl[..., 2].amax(1).clamp(min=0)
    return w / 2


def piece_radii(a: torch.Tensor, b: torch.Tensor, radii: torch.Tensor,
                piece_seg: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Radii of pieces with ends a, b (N, D): (r_a, r_b) (N,) each, clamped at 0, for
    D = 3; else (radii[piece_seg], None), one radius per piece."""
    if a.shape[-1] == 3:
        return a[:, 2].clamp(min=0), b[:, 2].clamp(min=0)
    return radii.index_select(0, piece_seg), None


def _reach(r: torch.Tensor, r_end: torch.Tensor | None) -> torch.Tensor:
    """Largest radius of each piece (N,): r, or max(r_a, r_b)."""
    return r if r_end is None else torch.maximum(r, r_end)


def _finite(x: torch.Tensor) -> torch.Tensor:
    """Detached copy with NaN → 0 and ±inf → the largest finite values: safe to size from."""
    return torch.nan_to_num(x.detach(), nan=0.0)


def piece_cap(height: int, width: int) -> int:
    """Most pieces of one segment: enough for a curve four times around the canvas; bounds
    the memory a wild trajectory can ask for."""
    return math.ceil(4 * (height + width) / PIECE_LENGTH) + 4


def piece_counts(ctrl: torch.Tensor, radii: torch.Tensor, height: int, width: int) -> torch.Tensor:
    """Number of straight pieces per segment (S,), detached, 0 for segments off the canvas.
    ``ctrl`` (S, 4, D): only x, y count; ``radii`` (S,) the largest radius of each segment.

    n = max(⌈|control polygon| / PIECE_LENGTH⌉, ⌈√(0.75·M / FLATNESS)⌉, 1), with
    M = max(|P0 − 2P1 + P2|, |P1 − 2P2 + P3|): the chord error of n uniform pieces is at most
    max|B''| / (8n²) ≤ 6M / (8n²). A segment whose control hull, grown by r + 1, misses the
    canvas gets 0 (the curve lies inside its control hull). Non-finite input gives finite
    counts (at most the cap), never a huge allocation.
    """
    with torch.no_grad():
        ctrl, radii = _finite(ctrl[..., :2]), _finite(radii)  # (S, 4, 2), (S,)
        legs = ctrl[:, 1:] - ctrl[:, :-1]  # (S, 3, 2)
        poly = planar_norm(legs).sum(-1)  # (S,)
        bend = planar_norm(legs[:, 1:] - legs[:, :-1]).amax(-1)  # (S,)
        n = torch.maximum(torch.ceil(poly / PIECE_LENGTH),
                          torch.ceil(torch.sqrt(0.75 * bend / FLATNESS))).clamp(min=1)
        n = n.clamp(max=piece_cap(height, width)).long()
        grow = (radii + 1)[:, None]  # (S, 1)
        lo, hi = ctrl.amin(1) - grow, ctrl.amax(1) + grow  # (S, 2)
        inside = (hi[:, 0] > 0) & (hi[:, 1] > 0) & (lo[:, 0] < width) & (lo[:, 1] < height)
        return n * inside


def _cubic_points(ctrl: torch.Tensor, seg: torch.Tensor, u: torch.Tensor) -> torch.Tensor:
    """B(u) = (1−u)³P0 + 3u(1−u)²P1 + 3u²(1−u)P2 + u³P3 of segments ``seg`` (K,) at u (K,):
    (K, D), differentiable in ctrl (S, 4, D)."""
    u = u[:, None]  # (K, 1)
    v = 1 - u
    basis = torch.cat((v * v * v, 3 * u * v * v, 3 * u * u * v, u * u * u), 1)  # (K, 4)
    return torch.einsum("pk,pkd->pd", basis, ctrl.index_select(0, seg))


def flatten(ctrl: torch.Tensor, counts: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor,
                                                                  torch.Tensor]:
    """Chop each cubic into ``counts[s]`` chords between the parameters u = k / counts[s].

    Returns the pieces' start points (N, D), end points (N, D) and segment index (N,),
    N = Σ counts (read from the device); differentiable in ctrl (S, 4, D).
    """
    n_seg, dev = ctrl.shape[0], ctrl.device
    seg_ids = torch.arange(n_seg, device=dev)
    npts = counts + (counts > 0)  # (S,) points per segment: n + 1, or 0 when culled
    point_seg = torch.repeat_interleave(seg_ids, npts)  # (P,)
    first = torch.cumsum(npts, 0) - npts  # (S,) index of each segment's first point
    k = torch.arange(point_seg.shape[0], device=dev) - first.index_select(0, point_seg)  # (P,)
    u = k.to(ctrl.dtype) / counts.index_select(0, point_seg).to(ctrl.dtype)  # (P,)
    pts = _cubic_points(ctrl, point_seg, u)  # (P, D)
    piece_seg = torch.repeat_interleave(seg_ids, counts)  # (N,)
    # piece j of segment s starts at point first[s] + (j − Σ_{s'<s} counts[s']) = j + (#segments
    # before s that have points); with culled segments that is j + rank of s among kept ones
    kept_rank = torch.cumsum(counts > 0, 0) - 1  # (S,)
    start = (torch.arange(piece_seg.shape[0], device=dev)
             + kept_rank.index_select(0, piece_seg))  # (N,)
    return pts.index_select(0, start), pts.index_select(0, start + 1), piece_seg


def flatten_static(ctrl: torch.Tensor, counts: torch.Tensor, pieces: int
                   ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """:func:`flatten` into exactly ``pieces`` pieces (static shape, no device read).

    Piece p belongs to segment s with ends[s−1] ≤ p < ends[s] (ends = cumsum(counts)) and
    runs from u = j/n to (j+1)/n, j = p − ends[s−1]; pieces past Σ counts are padding.
    Returns start points (B, D), end points (B, D), segment (B,), valid (B,) bool.
    """
    dtype, dev = ctrl.dtype, ctrl.device
    ends = torch.cumsum(counts, 0)  # (S,)
    p = torch.arange(pieces, device=dev)  # (B,)
    seg = torch.searchsorted(ends, p, right=True).clamp(max=max(ctrl.shape[0] - 1, 0))  # (B,)
    valid = p < ends[-1]
    n = counts[seg]  # (B,)
    j = torch.where(valid, p - (ends - counts)[seg], 0)  # (B,)
    n_f = n.clamp(min=1).to(dtype)
    a = _cubic_points(ctrl, seg, j.to(dtype) / n_f)
    b = _cubic_points(ctrl, seg, (j + 1).to(dtype) / n_f)
    return a, b, seg, valid


def fit_counts(counts: torch.Tensor, pieces: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Counts (S,) that fit ``pieces`` in all, and whether the originals (nearly) did not:
    a 0-d bool set past ``ALARM`` × pieces, so a replan usually comes before any coarsening.

    When Σ counts > pieces every kept segment gets max(1, ⌊n·(pieces − S)/Σn⌋) pieces, which
    sums to at most ``pieces``: a coarser curve, never a missing one.
    """
    total = counts.sum()
    scale = (pieces - counts.shape[0]) / total.clamp(min=1).to(torch.float64)
    coarse = torch.floor(counts.to(torch.float64) * scale).long().clamp(min=1) * (counts > 0)
    return torch.where(total > pieces, coarse, counts), total > ALARM * pieces


def pixel_ranges(a: torch.Tensor, b: torch.Tensor, r: torch.Tensor, height: int,
                 width: int, limits: torch.Tensor | None = None
                 ) -> tuple[torch.Tensor, torch.Tensor]:
    """First and last pixel (column, row) whose centre lies within r + ½ of each piece: c0
    in [0, size], c1 in [−1, size − 1], (N, 2) long each; c1 < c0 for a piece off the
    canvas. Detached, from finite copies: NaN input cannot give a wild index. a, b (N, D):
    only x, y count; r (N,) the largest radius of each piece. ``limits`` (N, 2): each
    piece's own canvas (width, height) instead (several canvases in one call)."""
    with torch.no_grad():
        a, b = _finite(a[:, :2]), _finite(b[:, :2])
        reach = (_finite(r) + 0.5)[:, None]  # (N, 1)
        lo = torch.minimum(a, b) - reach  # (N, 2)
        hi = torch.maximum(a, b) + reach
        size = (torch.arange(2, device=a.device) * (height - width) + width  # (W, H), no upload
                if limits is None else limits)
        c0 = torch.minimum((torch.floor(lo - 0.5) + 1).clamp(min=0), size)  # first centre > lo
        c1 = torch.minimum((torch.ceil(hi - 0.5) - 1).clamp(min=-1), size - 1)  # last < hi
        return c0.long(), c1.long()


def _excess(dx: torch.Tensor, dy: torch.Tensor, abx: torch.Tensor, aby: torch.Tensor,
            inv_len2: torch.Tensor, r: torch.Tensor, dr: torch.Tensor | None) -> torch.Tensor:
    """r(t) + ½ − d of pixel centres at (dx, dy) from a piece's start, the piece running
    along (abx, aby) with 1/|ab|² = ``inv_len2``: t = clamp(ap·ab / |ab|², 0, 1),
    d = |ap − t·ab|, r(t) = r + t·dr (dr = r_b − r_a, None for a constant radius). The
    coverage is its clamp to [0, 1]. Elementwise (any broadcastable shapes), so the dense
    patches and the few pixels the backward pass needs get the same bits."""
    eps, half = scalar_tensors(dx, _EPS, 0.5)
    t = ((dx * abx + dy * aby) * inv_len2).clamp(0, 1)
    ex, ey = dx - t * abx, dy - t * aby
    d = torch.sqrt(ex * ex + ey * ey + eps)
    rad = r if dr is None else r + t * dr
    return rad + half - d


class _MaxUnion(torch.autograd.Function):
    """``image``, the per-pixel maxima computed without a graph, with the gradient that
    ``scatter_reduce(..., "amax", include_self=True)`` gives its sources: each pixel's
    gradient shared evenly among the values equal to its maximum (``share`` of them, the
    blank page's 0 among them where the maximum is 0), here for the only sources that can
    carry one, ``x``: the excess r + ½ − d of each maximum within [0, 1] of the clamp, at
    pixel ``pixel``."""

    @staticmethod
    def forward(ctx: Any, x: torch.Tensor, image: torch.Tensor, pixel: torch.Tensor,
                share: torch.Tensor) -> torch.Tensor:
        ctx.save_for_backward(pixel, share)
        return image

    @staticmethod
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor, None, None, None]:
        pixel, share = ctx.saved_tensors
        return grad.reshape(-1).index_select(0, pixel) / share, None, None, None


def capsule_coverage(
    a: torch.Tensor,  # (N, D) piece starts (x, y count)
    b: torch.Tensor,  # (N, D) piece ends
    r: torch.Tensor,  # (N,) radii, or the radii r_a at the starts
    c0: torch.Tensor,  # (N, 2) first pixel (column, row)
    c1: torch.Tensor,  # (N, 2) last pixel
    patch: tuple[int, int],  # (kx, ky) pixels evaluated from c0
    height: int,
    width: int,
    valid: torch.Tensor | None = None,  # (N,) bool: pieces to draw
    r_end: torch.Tensor | None = None,  # (N,) radii r_b at the ends (varying width)
    piece_image: torch.Tensor | None = None,  # (N,) long: the image of each piece
    count: int = 1,  # images drawn (with ``piece_image``)
    sparse_backward: bool = False,
) -> torch.Tensor:
    """Image (H, W), or (count, H, W) with ``piece_image``: per pixel the max over pieces
    of clamp(r + ½ − d, 0, 1), d the distance
    of the pixel centre to the capsule's axis, t = clamp(ap·ab / |ab|², 0, 1), d = |ap − t·ab|;
    with ``r_end``, r = r_a + t·(r_b − r_a) (the width varies along the piece).
    Only the patch of kx × ky pixels from c0 (clipped at c1) of each piece is evaluated.

    ``sparse_backward`` (reads the device): the patches are evaluated without a graph,
    and only the pixels' maxima within the clamp's [0, 1] — the anti-aliased rims, about
    6 % of a fit's patch pixels — are evaluated again with one, for the backward pass: the
    same image and, per pixel, the same gradient as the dense graph (:class:`_MaxUnion`),
    summed into each piece in another order (a fit step about 2 ms shorter here)."""
    kx, ky = patch
    if a.shape[1] != 2:
        a, b = a[:, :2], b[:, :2]  # (N, 2): the radius came in r, r_end
    dtype, dev = a.dtype, a.device
    with torch.no_grad():
        xs = c0[:, :1] + torch.arange(kx, device=dev)  # (N, kx) pixel columns
        ys = c0[:, 1:] + torch.arange(ky, device=dev)  # (N, ky) pixel rows
        inside = (ys <= c1[:, 1:])[:, :, None] & (xs <= c1[:, :1])[:, None, :]  # (N, ky, kx)
        if valid is not None:
            inside = inside & valid[:, None, None]
        row = ys.minimum(c1[:, 1:]).clamp(min=0)[:, :, None]
        flat = row * width + xs.minimum(c1[:, :1]).clamp(min=0)[:, None, :]  # (N, ky, kx)
        if piece_image is not None:
            flat = flat + (piece_image * (height * width))[:, None, None]
    pages = 1 if piece_image is None else count
    shape = (height, width) if piece_image is None else (count, height, width)
    sparse = sparse_backward and torch.is_grad_enabled() and any(
        t is not None and t.requires_grad for t in (a, b, r, r_end))

    ab = b - a  # (N, 2)
    inv_len2 = torch.reciprocal((ab * ab).sum(1).clamp(min=1e-12))  # (N,)
    dr = None if r_end is None else r_end - r  # (N,)
    half = scalar_tensors(a, 0.5)[0]  # pixel centres at + ½
    with torch.no_grad() if sparse else contextlib.nullcontext():
        dx = (xs.to(dtype) + half - a[:, :1])[:, None, :]  # (N, 1, kx)
        dy = (ys.to(dtype) + half - a[:, 1:])[:, :, None]  # (N, ky, 1)
        at = (slice(None), None, None)  # (N, 1, 1)
        x = _excess(dx, dy, ab[at + (0,)], ab[at + (1,)], inv_len2[at], r[at],
                    None if dr is None else dr[at])  # (N, ky, kx)
        cov = x.clamp(0, 1) * inside  # (N, ky, kx)
        img = torch.zeros(pages * height * width, dtype=dtype, device=dev).scatter_reduce_(
            0, flat.reshape(-1), cov.reshape(-1), reduce="amax", include_self=True)
    if sparse:
        with torch.no_grad():
            flat = flat.reshape(-1)
            top = cov.reshape(-1) == img.index_select(0, flat)
            tops = torch.zeros_like(img).scatter_add_(0, flat, top.to(dtype))  # per pixel
            rim = (top & inside.reshape(-1) & (x.reshape(-1) >= 0)
                   & (x.reshape(-1) <= 1)).nonzero().squeeze(1)  # (K,) patch entries
            piece, within = rim // (ky * kx), rim % (ky * kx)
            pixel = flat.index_select(0, rim)
            # the values equal to each rim pixel's maximum: its patch entries and, where
            # the maximum is 0, the blank page's (small whole numbers: exact in any order)
            share = tops.index_select(0, pixel) + (img.index_select(0, pixel) == 0).to(dtype)
            x_at = xs.reshape(-1).index_select(0, piece * kx + within % kx).to(dtype)
            y_at = ys.reshape(-1).index_select(0, piece * ky + within // kx).to(dtype)
        # index_select, not a[piece, 0]: a third of the cost per gather here; one column at
        # a time, as before, so the gradients add up in the same order (the same bits)
        x_rim = _excess(x_at + half - a[:, 0].index_select(0, piece),
                        y_at + half - a[:, 1].index_select(0, piece),
                        ab[:, 0].index_select(0, piece), ab[:, 1].index_select(0, piece),
                        inv_len2.index_select(0, piece),
                        r.index_select(0, piece),
                        None if dr is None else dr.index_select(0, piece))  # (K,)
        img = _MaxUnion.apply(x_rim, img, pixel, share)
    return img.reshape(shape)


def _inputs_sum(ctrl: torch.Tensor, w: torch.Tensor) -> torch.Tensor:
    """Σ of the inputs the image depends on (0-d): the control points, and the widths unless
    the segments carry their own radius (then the widths are ignored)."""
    return ctrl.sum() if _varying(ctrl) else ctrl.sum() + w.sum()


def _image_sums(ctrl: torch.Tensor, w: torch.Tensor, canvases: Canvases) -> torch.Tensor:
    """:func:`_inputs_sum` per image (count,): each drawing's NaN stays its own."""
    per_segment = ctrl.sum((1, 2)) if _varying(ctrl) else ctrl.sum((1, 2)) + w
    return per_segment.new_zeros(canvases.count).index_add(0, canvases.image, per_segment)


def _paper(ctrl: torch.Tensor, w: torch.Tensor, height: int, width: int,
           canvases: Canvases | None = None) -> torch.Tensor:
    """A blank image (H, W), or (count, H, W), that keeps the graph to the inputs (zero
    gradient)."""
    if canvases is not None:
        return (ctrl.new_zeros(canvases.count, height, width)
                + 0 * _image_sums(ctrl, w, canvases)[:, None, None])
    return ctrl.new_zeros(height, width) + 0 * _inputs_sum(ctrl, w)


def _poison(img: torch.Tensor, ctrl: torch.Tensor, w: torch.Tensor,
            canvases: Canvases | None = None) -> torch.Tensor:
    """``img`` unchanged, or all NaN when a coordinate, radius or width is not finite (no
    device read): unchecked NaN input must reach the loss, where the fitting loop looks.
    With ``canvases``, only the image of the drawing with the NaN."""
    if canvases is not None:
        return img + 0 * _image_sums(ctrl, w, canvases)[:, None, None]
    return img + 0 * _inputs_sum(ctrl, w)


# --- the two paths ---------------------------------------------------------------------------
def _check_canvases(canvases: Canvases | None, n_seg: int, height: int, width: int) -> None:
    if canvases is None:
        return
    if canvases.image.shape != (n_seg,) or canvases.sizes.shape != (canvases.count, 2):
        raise ValueError(f"Canvases need an image index per segment ({n_seg},) and a size "
                         f"per image ({canvases.count}, 2); got {tuple(canvases.image.shape)}"
                         f" and {tuple(canvases.sizes.shape)}.")


def _limits(canvases: Canvases | None, piece_seg: torch.Tensor
            ) -> tuple[torch.Tensor | None, torch.Tensor | None]:
    """Each piece's image (N,) and its canvas (width, height) (N, 2), or None, None."""
    if canvases is None:
        return None, None
    image = canvases.image[piece_seg]
    return image, canvases.sizes[image]


def render_segments(
    segments: torch.Tensor, widths: torch.Tensor | float, height: int, width: int,
    check: bool = True, canvases: Canvases | None = None,
) -> torch.Tensor:
    """Render cubic Bézier segments in pixel coordinates (x right, y down; pixel (r, c)
    centred at (c + ½, r + ½)) to a coverage image (H, W) in [0, 1]: segments (S, 4, 2) with
    stroke widths (S,) or a number, I(p) = max over pieces of clamp(w/2 + ½ − d(p), 0, 1);
    or segments (S, 4, 3) whose 3rd coordinate is the radius in px (widths ignored), each
    piece's radius interpolated between its ends (module docstring). With ``canvases``,
    several drawings at once: a stack (count, H, W), each segment on its own image.

    Differentiable w.r.t. segments (radius included) and widths. Raises ValueError on bad
    shapes, and with ``check`` on NaN/inf input or negative widths or radii (without, NaN
    gives a NaN image and a negative radius draws nothing). Sizes follow the data (reads
    the device).
    """
    height, width = int(height), int(width)
    ctrl, w = check_inputs(segments, widths, height, width, check)
    _check_canvases(canvases, ctrl.shape[0], height, width)
    radii = segment_radii(ctrl, w)  # (S,)
    counts = piece_counts(ctrl, radii, height, width)  # (S,)
    if ctrl.shape[0] == 0 or int(counts.sum()) == 0:
        return _paper(ctrl, w, height, width, canvases)
    a, b, piece_seg = flatten(ctrl, counts)  # (N, D), (N, D), (N,)
    r, r_end = piece_radii(a, b, radii, piece_seg)  # (N,), (N,) or None
    image, limits = _limits(canvases, piece_seg)
    c0, c1 = pixel_ranges(a, b, _reach(r, r_end), height, width, limits)  # (N, 2) each
    keep = (c1 >= c0).all(1)  # (N,) pieces that touch the canvas
    if not bool(keep.all()):
        a, b, r, c0, c1 = a[keep], b[keep], r[keep], c0[keep], c1[keep]
        r_end = None if r_end is None else r_end[keep]
        image = None if image is None else image[keep]
    if a.shape[0] == 0:
        return _paper(ctrl, w, height, width, canvases)
    kx, ky = (c1 - c0 + 1).amax(0).tolist()  # patch size: the widest piece range
    img = capsule_coverage(a, b, r, c0, c1, (kx, ky), height, width, r_end=r_end,
                           piece_image=image, count=canvases.count if canvases else 1,
                           sparse_backward=True)
    return img if check else _poison(img, ctrl, w, canvases)


def render_segments_static(
    segments: torch.Tensor, widths: torch.Tensor | float, height: int, width: int,
    budget: RasterBudget, check: bool = False, canvases: Canvases | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`render_segments` (segments (S, 4, 2) with widths, or (S, 4, 3) with radii;
    several drawings with ``canvases``) with the static sizes of ``budget``: no device read,
    the same image while the data fit it.
    Returns the image (H, W) and a 0-d bool on the device, True when they (nearly) outgrew
    it: past ``ALARM`` of the pieces or a piece as wide as the patch; past the budget
    itself the curve is drawn with fewer pieces or clipped patches. NaN input gives a NaN
    image unless ``check`` (which reads the device).
    """
    height, width = int(height), int(width)
    ctrl, w = check_inputs(segments, widths, height, width, check)
    _check_canvases(canvases, ctrl.shape[0], height, width)
    if ctrl.shape[0] == 0:
        return _paper(ctrl, w, height, width, canvases), torch.zeros(
            (), dtype=torch.bool, device=ctrl.device)
    radii = segment_radii(ctrl, w)  # (S,)
    counts, too_many = fit_counts(piece_counts(ctrl, radii, height, width), budget.pieces)
    a, b, piece_seg, valid = flatten_static(ctrl, counts, budget.pieces)  # (B, ...)
    r, r_end = piece_radii(a, b, radii, piece_seg)  # (B,), (B,) or None
    image, limits = _limits(canvases, piece_seg)
    c0, c1 = pixel_ranges(a, b, _reach(r, r_end), height, width, limits)  # (B, 2) each
    with torch.no_grad():  # pieces on the canvas as wide as the patch
        extent = c1 - c0 + 1  # (B, 2), ≤ 0 off the canvas
        too_wide = (((extent[:, 0] >= budget.patch_x) | (extent[:, 1] >= budget.patch_y))
                    & (extent > 0).all(1) & valid).any()
    img = capsule_coverage(a, b, r, c0, c1, (budget.patch_x, budget.patch_y), height, width,
                           valid, r_end, image, canvases.count if canvases else 1)
    return _poison(img, ctrl, w, canvases), too_many | too_wide


def plan_budget(segments: torch.Tensor, widths: torch.Tensor | float, height: int,
                width: int, headroom: float = HEADROOM) -> RasterBudget:
    """A :class:`RasterBudget` for segments (S, 4, 2 or 3) like these (reads the device,
    once): the pieces
    they need × ``headroom`` plus one per segment, and the widest piece's pixel range plus
    ``PATCH_MARGIN``, within the bounds of :func:`render_segments` (at most
    :func:`piece_cap` pieces per segment, a patch at most the canvas)."""
    height, width = int(height), int(width)
    with torch.no_grad():
        ctrl, w = check_inputs(segments, widths, height, width, check=False)
        n_seg = ctrl.shape[0]
        radii = segment_radii(ctrl, w)  # (S,)
        counts = piece_counts(ctrl, radii, height, width)
        total = int(counts.sum())
        pieces = min(math.ceil(headroom * total) + n_seg, piece_cap(height, width) * n_seg)
        kx = ky = 1
        if total > 0:
            a, b, piece_seg = flatten(ctrl, counts)
            c0, c1 = pixel_ranges(a, b, _reach(*piece_radii(a, b, radii, piece_seg)),
                                  height, width)
            extent = torch.where((c1 >= c0).all(1, keepdim=True), c1 - c0 + 1, 1)
            kx, ky = extent.amax(0).tolist()
        bound = lambda k, side: max(1, min(k + PATCH_MARGIN, side + 1))  # noqa: E731
        return RasterBudget(max(pieces, 1), bound(kx, width), bound(ky, height))


class RasterSession:
    """The renderer of one fit: static budgets (by segment count, canvas, device, dtype),
    planned on first use, and a device-side flag OR-ed over calls saying a budget was too
    small. :meth:`replan_if_needed` reads the flag (one device read) and drops the budgets
    so the next call plans them again. ``static=False`` renders with :func:`render_segments`
    (sized per call), the better choice on a CPU where a device read costs nothing.
    """

    def __init__(self, static: bool = True, check: bool = False) -> None:
        self.static = static
        self.check = check
        self.budgets: dict[tuple, RasterBudget] = {}
        self.overflow: torch.Tensor | None = None  # 0-d bool on the device

    #: renders several drawings in one call (``canvases``): a batched fit asks for it
    renders_canvases = True

    def __call__(self, segments: torch.Tensor, widths: torch.Tensor | float, height: int,
                 width: int, canvases: Canvases | None = None) -> torch.Tensor:
        """Coverage image (H, W) of cubic segments (S, 4, 2) with widths (S,) or a number,
        or (S, 4, 3) whose 3rd coordinate is the radius in px (widths ignored); a stack
        (count, H, W) of several drawings with ``canvases``."""
        if not self.static:
            return render_segments(segments, widths, height, width, check=self.check,
                                   canvases=canvases)
        key = (tuple(segments.shape), int(height), int(width), segments.device, segments.dtype,
               canvases.count if canvases is not None else 0)
        budget = self.budgets.get(key)
        if budget is None:
            budget = self.budgets[key] = plan_budget(segments, widths, height, width)
        img, over = render_segments_static(segments, widths, height, width, budget,
                                           self.check, canvases)
        self.overflow = over if self.overflow is None else self.overflow | over
        return img

    def replan_if_needed(self) -> bool:
        """True (and the budgets dropped) when a call since the last check outgrew its
        budget. Reads one flag from the device."""
        if self.overflow is None or not bool(self.overflow):
            return False
        self.budgets.clear()
        self.overflow = None
        return True
