"""Tests of the built-in 'raster' renderer (plugins/raster.py)."""

from __future__ import annotations

import math

import pytest
import torch

import inkmotion
from inkmotion.plugins.raster import RasterRenderer, render_segments

DEVICES = [
    "cpu",
    pytest.param("cuda", marks=pytest.mark.skipif(not torch.cuda.is_available(),
                                                   reason="CUDA not available")),
]


def line_segment(p0: tuple[float, float], p1: tuple[float, float],
                 dtype: torch.dtype = torch.float32, device: str = "cpu") -> torch.Tensor:
    """A straight cubic (1, 4, 2) from p0 to p1 with control points at the thirds."""
    a, b = torch.tensor(p0, dtype=dtype), torch.tensor(p1, dtype=dtype)
    return torch.stack([a, a + (b - a) / 3, a + 2 * (b - a) / 3, b])[None].to(device)


def split_cubic(seg: torch.Tensor, u: float) -> tuple[torch.Tensor, torch.Tensor]:
    """De Casteljau split of cubics (S, 4, 2) at parameter u into two halves."""
    p0, p1, p2, p3 = seg.unbind(1)
    q0, q1, q2 = p0 + u * (p1 - p0), p1 + u * (p2 - p1), p2 + u * (p3 - p2)
    r0, r1 = q0 + u * (q1 - q0), q1 + u * (q2 - q1)
    s = r0 + u * (r1 - r0)
    return torch.stack([p0, q0, r0, s], 1), torch.stack([s, r1, q2, p3], 1)


CURVE = torch.tensor([[[10.3, 40.2], [30.7, 5.1], [60.2, 70.4], [85.6, 20.9]]],
                     dtype=torch.float64)


def test_plugin_registered() -> None:
    renderer = inkmotion.plugin("renderer", "raster")
    assert renderer.name == "raster" and renderer.description
    img = renderer(CURVE.float(), 3.0, 64, 96)
    assert torch.equal(img, render_segments(CURVE.float(), 3.0, 64, 96))


def test_gradcheck_control_points_and_widths() -> None:
    seg = torch.tensor([[[4.31, 6.17], [9.73, 2.29], [14.58, 17.61], [21.13, 11.47]],
                        [[3.57, 19.81], [7.12, 21.33], [11.91, 20.62], [16.44, 22.05]]],
                       dtype=torch.float64, requires_grad=True)
    widths = torch.tensor([3.37, 2.21], dtype=torch.float64, requires_grad=True)
    weights = torch.rand(26, 25, generator=torch.Generator().manual_seed(0), dtype=torch.float64)

    def loss(s: torch.Tensor, w: torch.Tensor) -> torch.Tensor:
        return (render_segments(s, w, 26, 25) * weights).sum()

    assert torch.autograd.gradcheck(loss, (seg, widths), eps=1e-6, atol=1e-5, rtol=1e-4)


def test_gradients_reach_every_input() -> None:
    seg = CURVE.clone().requires_grad_(True)
    w = torch.tensor([2.5], dtype=torch.float64, requires_grad=True)
    render_segments(seg, w, 64, 96).sum().backward()
    assert seg.grad is not None and torch.isfinite(seg.grad).all() and seg.grad.abs().sum() > 0
    assert w.grad is not None and w.grad.item() > 0  # wider stroke, more ink


DIAGONAL_END = (50.0 + 200 / math.sqrt(2), 100.3 + 200 / math.sqrt(2))


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
@pytest.mark.parametrize("end", [(250.0, 100.3), DIAGONAL_END])
def test_straight_stroke_area(dtype: torch.dtype, end: tuple[float, float]) -> None:
    """Area of a 200 px stroke of width 3 is 600 px² (+ round caps π·r², about 1.2%)."""
    img = render_segments(line_segment((50.0, 100.3), end, dtype), 3.0, 300, 300)
    assert img.dtype == dtype
    assert abs(img.sum().item() - 600.0) / 600.0 < 0.02


@pytest.mark.parametrize("device", DEVICES)
def test_range_shape_and_device(device: str) -> None:
    seg = CURVE.float().to(device)
    img = render_segments(seg, torch.tensor([4.0], device=device), 64, 96)
    assert img.shape == (64, 96) and img.device.type == device
    assert img.min() >= 0 and img.max() <= 1 and img.max() == 1


@pytest.mark.parametrize("device", DEVICES)
def test_cuda_matches_cpu(device: str) -> None:
    cpu = render_segments(CURVE, 3.0, 64, 96)
    dev = render_segments(CURVE.to(device), 3.0, 64, 96).cpu()
    assert torch.allclose(cpu, dev, atol=1e-9)


def test_no_segments_gives_paper() -> None:
    img = render_segments(torch.zeros(0, 4, 2), torch.zeros(0), 10, 12)
    assert img.shape == (10, 12) and (img == 0).all()


def test_off_canvas_segment_gives_paper_and_grad() -> None:
    seg = line_segment((-50.0, -20.0), (-10.0, -30.0)).requires_grad_(True)
    img = render_segments(seg, 3.0, 20, 20)
    assert (img == 0).all()
    img.sum().backward()
    assert seg.grad is not None and (seg.grad == 0).all()


def test_partly_off_canvas() -> None:
    img = render_segments(line_segment((-50.0, 10.5), (10.0, 10.5)), 3.0, 20, 20)
    assert abs(img.sum().item() - 3.0 * 10.0 - 0.5 * math.pi * 2.25) < 0.5


def test_zero_length_segment() -> None:
    seg = torch.tensor([[[10.2, 10.7]] * 4], requires_grad=True)
    img = render_segments(seg, 3.0, 20, 20)
    assert abs(img.sum().item() - math.pi * 2.25) < 0.3  # a round dot
    img.sum().backward()
    assert seg.grad is not None and torch.isfinite(seg.grad).all()


def test_per_segment_widths() -> None:
    seg = torch.cat([line_segment((10.0, 20.5), (90.0, 20.5)),
                     line_segment((10.0, 60.5), (90.0, 60.5))])
    img = render_segments(seg, torch.tensor([2.0, 8.0]), 80, 100)
    thin, thick = img[:40, 30:70].sum(0), img[40:, 30:70].sum(0)  # ink per column
    assert torch.allclose(thin, torch.full_like(thin, 2.0), atol=1e-4)
    assert torch.allclose(thick, torch.full_like(thick, 8.0), atol=1e-4)


def test_radius_column_is_ignored() -> None:
    seg3 = torch.cat([CURVE, torch.full((1, 4, 1), 7.0, dtype=torch.float64)], 2)
    assert torch.equal(render_segments(seg3, 3.0, 64, 96), render_segments(CURVE, 3.0, 64, 96))


@pytest.mark.parametrize("bad", ["segments", "widths"])
def test_nan_raises_value_error(bad: str) -> None:
    seg, w = CURVE.clone(), torch.tensor([3.0], dtype=torch.float64)
    (seg if bad == "segments" else w)[0, ...] = math.nan
    with pytest.raises(ValueError, match="NaN"):
        render_segments(seg, w, 64, 96)


def test_bad_shape_raises_value_error() -> None:
    with pytest.raises(ValueError, match="shape"):
        render_segments(torch.zeros(3, 2), 3.0, 10, 10)


def test_split_curve_renders_the_same() -> None:
    whole = render_segments(CURVE, 3.0, 64, 96)
    left, right = split_cubic(CURVE, 0.37)
    l1, l2 = split_cubic(left, 0.5)
    split = render_segments(torch.cat([l1, l2, right]), 3.0, 64, 96)
    assert (whole - split).abs().max() < 0.1
    assert (whole - split).abs().sum() < 0.01 * whole.sum()


def test_renderer_object_accepts_tensor_widths() -> None:
    img = RasterRenderer()(CURVE, torch.tensor([3.0], dtype=torch.float64), 64, 96)
    assert img.dtype == torch.float64
