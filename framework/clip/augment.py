"""CLIPDraw's augmentations, differentiable and batched: random perspective, then a random
resized crop to CLIP's input size, filled with white paper.

CLIPDraw (Frans et al. 2022) and CLIPasso score n random views of the drawing instead of
the drawing itself, so the optimiser cannot satisfy CLIP with adversarial pixel patterns;
the views are torchvision's ``RandomPerspective(distortion_scale, p=1, fill=1)`` followed
by ``RandomResizedCrop(size, scale)``. Here both are one homography per view, applied with
one ``grid_sample``, in normalised coordinates [−1, 1]² (x right, y down):

- perspective: each image corner c = (±1, ±1) moves inwards to e = c − sign(c)·(u, v),
  u, v ~ U(0, d) independently (torchvision's offsets, up to its integer pixels), and the
  view samples the input at P(q), P the homography with P(e_k) = c_k;
- crop: a box of area fraction s ~ U(scale) and aspect r (log-uniform in ``ratio``, relative
  to the image's own aspect), half sides (√(s·r), √(s/r)) clamped to 1, centred uniformly
  where it fits, resized to ``out_size`` × ``out_size``: q = C·o for o the view's pixel.

A view is M = P·C (output pixel -> input point); outside the input, the view is white
(sampling image − 1 with zero padding, then adding 1). The parameters are the matrices
M (n, 3, 3), independent of resolution, so the *same* views can be applied to two images
(clip-visual's target and rendering). Everything is drawn with torch's RNG on the device
(the job shell seeds it): no host synchronisation. An input larger than ``out_size`` is
first resized (bilinear, antialiased) so that its longer side is ``out_size``: the crop
then samples at most about 1:1 and thin strokes do not alias away.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F

#: torchvision's RandomResizedCrop default aspect-ratio range
DEFAULT_RATIO = (3 / 4, 4 / 3)


def _corners(dtype: torch.dtype, device: torch.device | str | None) -> torch.Tensor:
    """(4, 2) the corners of [−1, 1]²: top-left, top-right, bottom-right, bottom-left
    (made on the device, not uploaded)."""
    k = torch.arange(4, device=device)
    x = torch.where((k == 1) | (k == 2), 1.0, -1.0)
    y = torch.where(k >= 2, 1.0, -1.0)
    return torch.stack((x, y), -1).to(dtype)


def square_to_quad(quad: torch.Tensor) -> torch.Tensor:
    """(n, 3, 3) homographies Q with Q(c_k) = quad_k for the corners c_k of [−1, 1]²
    (order: top-left, top-right, bottom-right, bottom-left); ``quad`` (n, 4, 2).

    Heckbert's closed form for the unit square (1989, "Fundamentals of texture mapping"),
    composed with [−1, 1] -> [0, 1]; no linear solve, so no device read.
    """
    x0, x1, x2, x3 = quad[..., 0].unbind(-1)
    y0, y1, y2, y3 = quad[..., 1].unbind(-1)
    dx1, dx2, dx3 = x1 - x2, x3 - x2, x0 - x1 + x2 - x3
    dy1, dy2, dy3 = y1 - y2, y3 - y2, y0 - y1 + y2 - y3
    den = dx1 * dy2 - dx2 * dy1  # ≠ 0 for a convex quad
    g = (dx3 * dy2 - dx2 * dy3) / den
    h = (dx1 * dy3 - dx3 * dy1) / den
    one = torch.ones_like(g)
    unit = torch.stack((
        torch.stack((x1 - x0 + g * x1, x3 - x0 + h * x3, x0), -1),
        torch.stack((y1 - y0 + g * y1, y3 - y0 + h * y3, y0), -1),
        torch.stack((g, h, one), -1),
    ), -2)  # (n, 3, 3) unit square -> quad
    # · [[½, 0, ½], [0, ½, ½], [0, 0, 1]] ([−1, 1] -> [0, 1]), written out (no upload)
    c0, c1, c2 = unit.unbind(-1)
    return torch.stack((c0 / 2, c1 / 2, (c0 + c1) / 2 + c2), -1)


def inverse_homography(m: torch.Tensor) -> torch.Tensor:
    """(n, 3, 3) inverses up to scale (the adjugate: enough for a homography), no solve."""
    c0, c1, c2 = m.unbind(-1)  # columns
    return torch.stack((torch.linalg.cross(c1, c2), torch.linalg.cross(c2, c0),
                        torch.linalg.cross(c0, c1)), -2)


def perspective_matrices(ends: torch.Tensor) -> torch.Tensor:
    """(n, 3, 3) P mapping a view's point to the input point it shows, when the input's
    corners move to ``ends`` (n, 4, 2) (torchvision's ``perspective(img, corners, ends)``)."""
    return inverse_homography(square_to_quad(ends))


def crop_matrices(half: torch.Tensor, centre: torch.Tensor) -> torch.Tensor:
    """(n, 3, 3) C mapping [−1, 1]² onto boxes with half sides ``half`` (n, 2) and centres
    ``centre`` (n, 2)."""
    zero = torch.zeros_like(half[:, 0])
    one = torch.ones_like(zero)
    return torch.stack((
        torch.stack((half[:, 0], zero, centre[:, 0]), -1),
        torch.stack((zero, half[:, 1], centre[:, 1]), -1),
        torch.stack((zero, zero, one), -1),
    ), -2)


def sample_params(n: int, *, perspective: float = 0.5,
                  crop_scale: tuple[float, float] = (0.7, 0.9),
                  ratio: tuple[float, float] = DEFAULT_RATIO,
                  device: torch.device | str | None = None,
                  dtype: torch.dtype = torch.float32) -> torch.Tensor:
    """(n, 3, 3) random views M = P·C (see the module docstring), drawn on ``device``."""
    assert n >= 1 and 0 <= perspective <= 1 and 0 < crop_scale[0] <= crop_scale[1] <= 1
    corners = _corners(dtype, device)
    offsets = perspective * torch.rand(n, 4, 2, dtype=dtype, device=device)
    ends = corners - corners.sign() * offsets  # (n, 4, 2) corners moved inwards
    u = torch.rand(n, 4, dtype=dtype, device=device)
    area = crop_scale[0] + (crop_scale[1] - crop_scale[0]) * u[:, 0]
    log_r = math.log(ratio[0]) + (math.log(ratio[1]) - math.log(ratio[0])) * u[:, 1]
    r = log_r.exp()
    half = torch.stack(((area * r).sqrt(), (area / r).sqrt()), -1).clamp(max=1.0)  # (n, 2)
    centre = (1 - half) * (2 * u[:, 2:] - 1)
    return perspective_matrices(ends) @ crop_matrices(half, centre)


def sampling_grid(params: torch.Tensor, out_size: int) -> torch.Tensor:
    """(n, out, out, 2) the input points (x, y in [−1, 1]) each view's pixel shows
    (pixel centres, ``align_corners=False``)."""
    q = (2 * torch.arange(out_size, dtype=params.dtype, device=params.device) + 1) / out_size - 1
    y, x = torch.meshgrid(q, q, indexing="ij")
    pts = torch.stack((x, y, torch.ones_like(x)), -1).reshape(-1, 3)  # (out², 3)
    mapped = torch.einsum("nij,pj->npi", params, pts)  # (n, out², 3)
    grid = mapped[..., :2] / mapped[..., 2:]
    return grid.reshape(params.shape[0], out_size, out_size, 2)


def apply_params(images: torch.Tensor, params: torch.Tensor, out_size: int) -> torch.Tensor:
    """(n·B, 3, out, out) the views ``params`` (n, 3, 3) of ``images`` (B, 3, H, W) or
    (3, H, W) RGB in [0, 1]: row k·B + b is view k of image b. White outside the image."""
    x = images[None] if images.ndim == 3 else images
    b, c, h, w = x.shape
    if max(h, w) > out_size:  # antialiased downscale first (see the module docstring)
        s = out_size / max(h, w)
        x = F.interpolate(x, size=(max(1, round(h * s)), max(1, round(w * s))),
                          mode="bilinear", antialias=True, align_corners=False)
    n = params.shape[0]
    grid = sampling_grid(params.to(x.dtype), out_size).reshape(1, n * out_size, out_size, 2)
    views = F.grid_sample(x - 1, grid.expand(b, -1, -1, -1), mode="bilinear",
                          padding_mode="zeros", align_corners=False) + 1  # (B, C, n·out, out)
    views = views.reshape(b, c, n, out_size, out_size).permute(2, 0, 1, 3, 4)
    return views.reshape(n * b, c, out_size, out_size)


def augment(images: torch.Tensor, n: int, *, perspective: float = 0.5,
            crop_scale: tuple[float, float] = (0.7, 0.9), out_size: int = 224,
            params: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """n random CLIPDraw views of each image: ``(views (n·B, 3, out, out), params)``.

    Pass the returned ``params`` (n, 3, 3) back to apply the same views to another image.
    Differentiable with respect to ``images``.
    """
    if params is None:
        params = sample_params(n, perspective=perspective, crop_scale=crop_scale,
                               device=images.device)
    assert params.shape == (n, 3, 3), params.shape
    return apply_params(images, params, out_size), params
