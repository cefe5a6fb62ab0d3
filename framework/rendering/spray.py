"""Spray paint as an expected density: the differentiable mode of the 'spray' renderer
(the paper's Fig. 3b, without the randomness).

A spray can deposits paint at a constant flow while it moves, spread around the nozzle's
path. Along a ΣΛ trajectory sampled uniformly in time, every Hermite cubic segment lasts
the same time, so a segment's speed is its parameter speed |B'(u)| (px per segment time).
Each segment is sampled at ``per_segment`` points u_k = (k + ½)/K, and each sample is a
normalised Gaussian splat

    ρ(x) += (F/K) · N(x; B(u_k), σ_k² I),    σ_k = σ_0 · clamp((v_ref / v_k)^β, 1/c, c)

with v_k = |B'(u_k)|, v_ref the median sample speed of the drawing (differentiable like
the rest: its gradient goes to the median sample), σ_0 = w/2 the stroke's half width,
β = ``spread_exponent`` and c = ``spread_cap``. The paint deposited per unit length, ∫ρ
across the path, is F/v: it grows as the pen slows, exactly inversely to the speed; the
spread grows too, but as v^−β with β < 1, so a slow stretch is both wider and darker. The
flow F is set so that a straight line drawn at v_ref reaches an optical depth ``depth``
on its centre line: F = depth·√(2π)·σ_0·v_ref. The coverage returned is 1 − exp(−ρ) ∈
[0, 1) (paint as an absorbing layer), so it plugs into any image loss like the 'raster'
coverage.

Segments (S, 4, 3) carry a radius coordinate r; σ_0 = r there. Cost: S·K splats, each on a
static square patch of side 2⌈3 σ_max⌉ + 1 around it (σ_max = c·σ_0 of the widest
stroke), accumulated with ``index_add``; no data-dependent shapes besides that patch side,
read from the widths once per call, or once per fit by :class:`SpraySession`.
"""

from __future__ import annotations

import math

import torch

from inkmotion.portable_math import planar_norm

#: sample points per cubic segment
PER_SEGMENT = 8
#: σ ∝ (v_ref / v)^β
SPREAD_EXPONENT = 0.5
#: σ within [σ_0 / c, c·σ_0]
SPREAD_CAP = 2.0
#: the centre line's optical depth at the reference speed (coverage 1 − e^−3 = 0.95)
DEPTH = 3.0
#: patch half side in units of the largest σ
REACH = 3.0


def _bezier(ctrl: torch.Tensor, u: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Points and parameter derivatives (S, K, D) of cubics ``ctrl`` (S, 4, D) at ``u`` (K,)."""
    u = u[None, :, None]
    a = 1.0 - u
    p0, p1, p2, p3 = (ctrl[:, i, None, :] for i in range(4))
    point = a**3 * p0 + 3 * a**2 * u * p1 + 3 * a * u**2 * p2 + u**3 * p3
    deriv = 3 * a**2 * (p1 - p0) + 6 * a * u * (p2 - p1) + 3 * u**2 * (p3 - p2)
    return point, deriv


def splat_parameters(segments: torch.Tensor, widths: torch.Tensor | float,
                     per_segment: int = PER_SEGMENT, spread_exponent: float = SPREAD_EXPONENT,
                     spread_cap: float = SPREAD_CAP, depth: float = DEPTH
                     ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Centres (N, 2), spreads σ (N,) and masses (N,) of the splats of ``segments``
    (S, 4, 2|3) with ``widths`` (S,) (module docstring), N = S·K."""
    ctrl = segments
    s, k = ctrl.shape[0], per_segment
    u = (torch.arange(k, dtype=ctrl.dtype, device=ctrl.device) + 0.5) / k
    point, deriv = _bezier(ctrl, u)  # (S, K, D)
    if ctrl.shape[2] == 3:
        sigma0 = point[..., 2].clamp(min=0.05)  # (S, K) the radius coordinate
    else:
        w = torch.as_tensor(widths, dtype=ctrl.dtype, device=ctrl.device)
        sigma0 = (w.expand(s) / 2).clamp(min=0.05)[:, None].expand(s, k)
    speed = planar_norm(deriv) + 1e-6  # (S, K) px per segment time
    v_ref = speed.median()  # differentiable too (a median follows its element)
    spread = (v_ref / speed).pow(spread_exponent).clamp(1.0 / spread_cap, spread_cap)
    sigma = sigma0 * spread
    mass = depth * math.sqrt(2 * math.pi) * sigma0 * v_ref / k  # F/K, per stroke width
    return point[..., :2].reshape(-1, 2), sigma.reshape(-1), mass.reshape(-1)


def patch_half(widths: torch.Tensor | float, segments: torch.Tensor,
               spread_cap: float = SPREAD_CAP) -> int:
    """Half side (px) of the splats' patch: ⌈REACH·c·σ_0,max⌉ (one read of the device)."""
    radii = (segments[:, :, 2].abs() if segments.shape[2] == 3
             else torch.as_tensor(widths) / 2).detach()
    sigma0 = float(radii.max()) if radii.numel() else 1.0
    return max(1, math.ceil(REACH * spread_cap * max(sigma0, 0.05)))


def density(centres: torch.Tensor, sigma: torch.Tensor, mass: torch.Tensor, height: int,
            width: int, half: int) -> torch.Tensor:
    """The paint density (H, W): Σ mass·N(x; centre, σ²I) over the splats, each evaluated
    on the (2·half + 1)² pixels around it (pixel centres at integer + ½)."""
    offsets = torch.arange(-half, half + 1, device=centres.device)
    base = torch.floor(centres).long()  # (N, 2) the pixel holding the centre
    px = base[:, 0, None, None] + offsets[None, None, :]  # (N, 1, P)
    py = base[:, 1, None, None] + offsets[None, :, None]  # (N, P, 1)
    dx = px.to(centres.dtype) + 0.5 - centres[:, 0, None, None]
    dy = py.to(centres.dtype) + 0.5 - centres[:, 1, None, None]
    var = (sigma * sigma)[:, None, None]
    value = mass[:, None, None] / (2 * math.pi * var) * torch.exp(-(dx * dx + dy * dy) /
                                                                 (2 * var))  # (N, P, P)
    inside = (px >= 0) & (px < width) & (py >= 0) & (py < height)
    index = (py.clamp(0, height - 1) * width + px.clamp(0, width - 1)).expand_as(value)
    flat = torch.zeros(height * width, dtype=centres.dtype, device=centres.device)
    flat = flat.index_add(0, index.reshape(-1), (value * inside).reshape(-1))
    return flat.view(height, width)


def render_spray(segments: torch.Tensor, widths: torch.Tensor | float, height: int,
                 width: int, *, per_segment: int = PER_SEGMENT,
                 spread_exponent: float = SPREAD_EXPONENT, spread_cap: float = SPREAD_CAP,
                 depth: float = DEPTH, half: int | None = None) -> torch.Tensor:
    """Coverage (H, W) = 1 − exp(−ρ) of the expected spray density of ``segments``
    (module docstring). ``half``: the splat patch's half side (None: from the widths)."""
    if segments.ndim != 3 or segments.shape[1] != 4 or segments.shape[2] not in (2, 3):
        raise ValueError(f"segments must be (S, 4, 2|3), got {tuple(segments.shape)}")
    if len(segments) == 0:
        return segments.new_zeros(height, width)
    centres, sigma, mass = splat_parameters(segments, widths, per_segment, spread_exponent,
                                            spread_cap, depth)
    if half is None:
        half = patch_half(widths, segments, spread_cap)
    return 1.0 - torch.exp(-density(centres, sigma, mass, height, width, half))


class SpraySession:
    """:func:`render_spray` for the many calls of one fit: the splat patch's half side is
    read from the first call's widths (the only read of the device) and kept, so later
    calls have static shapes and never synchronise. Widths that grow past it clip the
    splats' tails (beyond 3 σ of the widest first stroke)."""

    def __init__(self) -> None:
        self.half: int | None = None

    def __call__(self, segments: torch.Tensor, widths: torch.Tensor | float, height: int,
                 width: int) -> torch.Tensor:
        if self.half is None:
            self.half = patch_half(widths, segments)
        return render_spray(segments, widths, height, width, half=self.half)
