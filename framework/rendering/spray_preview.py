"""Spray paint as an artist previews it: seeded particles along the ΣΛ motion, with drips
(the preview mode of the 'spray' renderer; the paper's Fig. 3b).

The motion is sampled uniformly in time, finely enough that consecutive samples are at
most ``step_px`` apart on the output canvas. Over a time step dt the nozzle emits a
Poisson number of particles with mean ``flow``·dt, so the paint per unit length is
inversely proportional to the speed; each particle lands at the nozzle position plus a
Gaussian offset of spread σ(v) = σ_0·clamp((v_ref/v)^β, 1/c, c) — the same law as the
differentiable mode (:mod:`inkmotion.rendering.spray`): σ_0 the stroke's half width, v_ref
the drawing's median speed. The flow is set so that a stretch at v_ref gets
``particles_per_px2`` particles per output px² on its centre line, √(2π)·σ_0 times that
per px of length, so the grain looks the same at any output size. Particles are accumulated into
an image, softened by a Gaussian blur of ``dot_px``, and turned into opacity
1 − exp(−amount/``saturation``).

Drips. Paint pools where the nozzle lingers: at each speed minimum of a path (prominence 5
% of its peak speed) the pooled paint is the flow × the time the nozzle spends within σ_0
of that point. Where it exceeds ``pool`` × what a pass at v_ref leaves on the same stretch,
a drip runs from the point along the canvas's down direction (+y: the GML reader turns a
tag so that its up vector is up), with a length proportional to the excess
(``drip_length`` stroke half-widths per unit of excess, so the same at any output size;
±20 % seeded jitter; at most ``max_drip`` of the canvas height), narrowing from the
stroke width to a third of it, ending in a round drop.

Everything random comes from one ``numpy.random.Generator(PCG64(seed))``: the same seed
gives the same image, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkmotion.rendering.spray import SPREAD_CAP, SPREAD_EXPONENT

#: px/s: the reference speed of a drawing that never moves (dots only)
STILL_PX_S = 50.0


@dataclass(frozen=True)
class SprayStyle:
    """How the preview paints (module docstring); colours are RGB in [0, 1]."""

    colour: tuple[float, float, float] = (0.08, 0.08, 0.1)
    paper: tuple[float, float, float] = (1.0, 1.0, 1.0)
    opacity: float = 0.95
    particles_per_px2: float = 6.0
    dot_px: float = 0.6
    saturation: float = 3.0
    step_px: float = 0.5
    spread_exponent: float = SPREAD_EXPONENT
    spread_cap: float = SPREAD_CAP
    pool: float = 2.0
    drip_length: float = 4.0
    max_drip: float = 0.2


@dataclass
class Drip:
    """A drip: where it starts (output px), its length (px) and the pooled paint ratio."""

    start: tuple[float, float]
    length: float
    pooled: float


@dataclass
class SprayPreview:
    """The RGB image (H, W, 3) uint8, the paint opacity (H, W) in [0, 1], the drips and
    the sample data they came from (per path: positions (n, 2) output px, speeds (n,))."""

    rgb: np.ndarray
    opacity: np.ndarray
    drips: list[Drip]
    samples: list[tuple[np.ndarray, np.ndarray]]


def _samples(plan: object, scale: float, step_px: float
             ) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Positions (n, 2) on the output canvas, planar speeds (n,) in output px/s, the time
    step of ``plan`` sampled uniformly in time at most ``step_px`` apart, and the pen's
    half width there (n,) in output px: a 2.5D plan's radius coordinate, else width / 2."""
    import torch

    from inkmotion.outputs.sampling import sample
    from inkmotion.sigma_lognormal.kinematics import kinematics

    coarse = sample(plan)  # to measure the length
    length = float(np.hypot(*np.diff(coarse.positions[:, :2], axis=0).T).sum()) * scale
    peak = float(coarse.speed.max()) * scale
    duration = float(coarse.t[-1])
    n = max(len(coarse.t), math.ceil(max(length / step_px, peak * duration / step_px)) + 1)
    t = torch.linspace(0.0, duration, n, dtype=torch.float64)
    p = plan.detached().to(device="cpu", dtype=torch.float64)  # type: ignore[attr-defined]
    with torch.no_grad():
        kin = kinematics(p, t)
    xy = kin.positions[:, :2].numpy() * scale
    speed = kin.velocities[:, :2].norm(dim=1).numpy() * scale
    half = (kin.positions[:, 2].numpy() * scale if kin.positions.shape[1] > 2
            else np.full(n, plan.width * scale / 2))  # type: ignore[attr-defined]
    return xy, speed, duration / (n - 1), np.maximum(half, 0.5)


def _spread(speed: np.ndarray, v_ref: float, sigma0: float | np.ndarray,
            style: SprayStyle) -> np.ndarray:
    ratio = (v_ref / np.maximum(speed, 1e-9)) ** style.spread_exponent
    return sigma0 * np.clip(ratio, 1.0 / style.spread_cap, style.spread_cap)


def drips_of(xy: np.ndarray, speed: np.ndarray, dt: float, flow: float, v_ref: float,
             sigma0: float, style: SprayStyle, rng: np.random.Generator,
             height: int) -> list[Drip]:
    """The drips of one path (module docstring)."""
    from inkmotion.speed_extrema import speed_minima

    out = []
    for i in speed_minima(speed, dt, prominence=0.05):
        near = np.hypot(*(xy - xy[i]).T) <= sigma0
        pooled = flow * dt * float(near.sum())
        passing = flow * (2 * sigma0) / v_ref  # what a pass at v_ref leaves there
        ratio = pooled / passing
        if ratio <= style.pool:
            continue
        jitter = 1.0 + 0.2 * (2.0 * rng.random() - 1.0)
        length = min(style.drip_length * sigma0 * (ratio - style.pool) * jitter,
                     style.max_drip * height)
        out.append(Drip((float(xy[i, 0]), float(xy[i, 1])), float(length), float(ratio)))
    return out


def _paint_drip(amount: np.ndarray, drip: Drip, sigma0: float, per_px2: float,
                rng: np.random.Generator) -> None:
    """Paint a drip as particles, ``per_px2`` per px² on average (Poisson), over its shape:
    a run narrowing from the stroke's width to a third of it, and a round drop."""
    import cv2

    shape = np.zeros_like(amount)
    x, y = drip.start
    steps = max(2, int(drip.length))
    for k in range(steps):
        f = k / (steps - 1)
        r = max(0.5, sigma0 * (1.0 - 2.0 * f / 3.0))
        cv2.circle(shape, (round(x * 4), round((y + f * drip.length) * 4)), round(r * 4),
                   1.0, thickness=-1, lineType=cv2.LINE_AA, shift=2)
    cv2.circle(shape, (round(x * 4), round((y + drip.length) * 4)), round(1.3 * sigma0 * 4),
               1.0, thickness=-1, lineType=cv2.LINE_AA, shift=2)
    amount += rng.poisson(shape * per_px2).astype(amount.dtype)


def spray_preview(drawing: object, size: int, seed: int = 0,
                  style: SprayStyle = SprayStyle()) -> SprayPreview:
    """The spray preview of ``drawing`` (a :class:`~inkmotion.sigma_lognormal.Drawing`) with
    its canvas's longer side at ``size`` px (module docstring)."""
    import cv2

    canvas = drawing.canvas  # type: ignore[attr-defined]
    scale = size / max(float(canvas[0]), float(canvas[1]))
    width, height = max(1, round(canvas[0] * scale)), max(1, round(canvas[1] * scale))
    rng = np.random.Generator(np.random.PCG64(seed))
    plans = drawing.plans  # type: ignore[attr-defined]
    samples = [_samples(p, scale, style.step_px) for p in plans]
    speeds = np.concatenate([s[1] for s in samples])
    moving = speeds[speeds > 1e-9 * max(float(speeds.max(initial=0.0)), 1.0)]
    # the median moving speed; a drawing of dots alone never moves: paint flows as at
    # STILL_PX_S (a dot then gets the paint of a stroke that long per second)
    v_ref = float(np.median(moving)) if len(moving) else STILL_PX_S
    amount = np.zeros((height, width), dtype=np.float32)
    drips: list[Drip] = []
    for xy, speed, dt, half in samples:
        # σ0 per sample: a varying width sprays each stretch as wide as its radius
        sigma0 = float(np.median(half))  # the drips' scale
        per_px = style.particles_per_px2 * math.sqrt(2 * math.pi) * half  # along a path
        flow = per_px * v_ref  # particles per s, per sample
        counts = rng.poisson(flow * dt, size=len(xy))
        spread = _spread(speed, v_ref, half, style)
        flow = float(np.median(flow))
        where = np.repeat(xy, counts, axis=0)
        where = where + rng.normal(size=where.shape) * np.repeat(spread, counts)[:, None]
        col = np.floor(where[:, 0]).astype(np.int64)
        row = np.floor(where[:, 1]).astype(np.int64)
        ok = (col >= 0) & (col < width) & (row >= 0) & (row < height)
        np.add.at(amount, (row[ok], col[ok]), 1.0)
        path_drips = drips_of(xy, speed, dt, flow, v_ref, sigma0, style, rng, height)
        for d in path_drips:
            _paint_drip(amount, d, sigma0, 1.5 * style.particles_per_px2, rng)
        drips.extend(path_drips)
    if style.dot_px > 0:
        amount = cv2.GaussianBlur(amount, (0, 0), style.dot_px)
    opacity = style.opacity * (1.0 - np.exp(-amount / style.saturation))
    paper, colour = np.asarray(style.paper), np.asarray(style.colour)
    rgb = paper[None, None, :] * (1.0 - opacity[..., None]) + colour * opacity[..., None]
    image = np.clip(np.round(rgb * 255.0), 0, 255).astype(np.uint8)
    return SprayPreview(image, opacity.astype(np.float64), drips,
                        [(s[0], s[1]) for s in samples])
