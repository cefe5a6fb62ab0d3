"""Benchmark of the 'raster' renderer against the project's dense baseline.

Scene: 750 cubic segments (Hermite → Bézier) of a smooth random Lissajous-like scribble on a
350×350 canvas, stroke width 3 px, segments about 4 px long. Timed: forward + backward of
sum(image · fixed random weights) w.r.t. control points and widths, median over repeats.
The baseline is :func:`inkmotion.benchmarks.dense_raster.render_dense`, written for this
benchmark: the same image, every piece measured against every pixel (no tiles, no
patches); it runs in the same process, on the same device, right after the renderer.
The project renderer runs as in a fit (:class:`RasterSession`): sized per call on the CPU,
static shapes elsewhere.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable

import torch

from inkmotion.benchmarks.kinematics import synchronize
from inkmotion.profiling.host_syncs import count_host_syncs
from inkmotion.rendering.raster import RasterSession

CANVAS = 350
SEGMENTS = 750
STROKE_WIDTH = 3.0


def scribble_segments(n: int = SEGMENTS, size: int = CANVAS, seed: int = 0) -> torch.Tensor:
    """Deterministic smooth scribble as cubic segments (n, 4, 2), float32, in pixels.

    x(t) = size/2 + Σ_j a_j sin(2π f_j t + φ_j) per axis (3 harmonics), sampled at n + 1
    uniform t; segment k = [x_k, x_k + v_k/(3n), x_{k+1} − v_{k+1}/(3n), x_{k+1}].
    """
    g = torch.Generator().manual_seed(seed)
    t = torch.linspace(0, 1, n + 1, dtype=torch.float64)  # (n+1,)
    freq = torch.randint(3, 9, (2, 3), generator=g).double()  # (2 axes, 3 harmonics)
    phase = torch.rand(2, 3, generator=g, dtype=torch.float64) * 2 * math.pi
    amp = torch.tensor([0.5, 0.3, 0.2], dtype=torch.float64) * 0.4 * size  # (3,)
    arg = 2 * math.pi * freq[..., None] * t + phase[..., None]  # (2, 3, n+1)
    pos = (amp[:, None] * torch.sin(arg)).sum(1).T + size / 2  # (n+1, 2)
    vel = (amp[:, None] * 2 * math.pi * freq[..., None] * torch.cos(arg)).sum(1).T  # (n+1, 2)
    h = 1 / (3 * n)
    seg = torch.stack((pos[:-1], pos[:-1] + h * vel[:-1], pos[1:] - h * vel[1:], pos[1:]), 1)
    return seg.float()


def _time_forward_backward(render: Callable[..., torch.Tensor], seg: torch.Tensor,
                           widths: torch.Tensor, repeats: int, warm_up: int = 3) -> float:
    """Median milliseconds of render + backward of sum(image · weights), on seg's device,
    after ``warm_up`` untimed calls."""
    device = seg.device
    weights = torch.rand(CANVAS, CANVAS, generator=torch.Generator().manual_seed(1)).to(device)

    def step() -> None:
        s = seg.clone().requires_grad_(True)
        w = widths.clone().requires_grad_(True)
        (render(s, w, CANVAS, CANVAS) * weights).sum().backward()

    for _ in range(warm_up):  # warm-up (and the session's planning call)
        step()
    times = []
    for _ in range(repeats):
        synchronize(device)
        t0 = time.perf_counter()
        step()
        synchronize(device)
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


def raster_host_syncs(render: Callable[..., torch.Tensor], seg: torch.Tensor,
                      widths: torch.Tensor) -> int:
    """Host synchronisations of one render + backward (after a first, planning, call)."""
    render(seg, widths, CANVAS, CANVAS)
    s = seg.clone().requires_grad_(True)
    with count_host_syncs() as log:
        render(s, widths, CANVAS, CANVAS).sum().backward()
    return log.count


def bench_raster(repeats: int = 20, device: torch.device | str = "cpu",
                 naive_repeats: int = 3) -> dict[str, float]:
    """Forward+backward median ms of the project renderer (as a fit runs it on ``device``)
    and of the dense baseline (same run, same device; ``naive_repeats``: it is slow) at
    350×350, 750 segments, width 3 px: {"raster_ms", "naive_ms", "speedup",
    "raster_host_syncs"}."""
    from inkmotion.benchmarks.dense_raster import render_dense

    device = torch.device(device)
    seg = scribble_segments().to(device)
    widths = torch.full((SEGMENTS,), STROKE_WIDTH, device=device)
    session = RasterSession(static=device.type != "cpu")
    raster_ms = _time_forward_backward(session, seg, widths, repeats)
    naive_ms = _time_forward_backward(render_dense, seg, widths, naive_repeats, warm_up=1)
    return {"raster_ms": raster_ms, "naive_ms": naive_ms, "speedup": naive_ms / raster_ms,
            "raster_host_syncs": raster_host_syncs(session, seg, widths)}


if __name__ == "__main__":
    print(bench_raster())
