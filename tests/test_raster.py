"""Tests of the built-in 'raster' renderer (rendering/raster.py, plugin plugins/raster.py).

Every image test runs on both paths: ``render_segments`` (sized per call) and
``render_segments_static`` (a budget planned once, static shapes).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
import torch

import inkmotion
from inkmotion.benchmarks.raster import scribble_segments
from inkmotion.plugins.raster import RasterRenderer
from inkmotion.rendering.raster import (
    RasterBudget,
    RasterSession,
    capsule_coverage,
    pixel_ranges,
    plan_budget,
    render_segments,
    render_segments_static,
)

Render = Callable[..., torch.Tensor]


def static_render(segments: torch.Tensor, widths: torch.Tensor | float, height: int,
                  width: int) -> torch.Tensor:
    """The static path with a budget planned on this very input, values checked."""
    budget = plan_budget(segments, widths, height, width)
    img, overflow = render_segments_static(segments, widths, height, width, budget, check=True)
    assert not bool(overflow)
    return img


@pytest.fixture(params=["dynamic", "static"])
def render(request: pytest.FixtureRequest) -> Render:
    return render_segments if request.param == "dynamic" else static_render


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


def test_gradcheck_control_points_and_widths(render: Render) -> None:
    seg = torch.tensor([[[4.31, 6.17], [9.73, 2.29], [14.58, 17.61], [21.13, 11.47]],
                        [[3.57, 19.81], [7.12, 21.33], [11.91, 20.62], [16.44, 22.05]]],
                       dtype=torch.float64, requires_grad=True)
    widths = torch.tensor([3.37, 2.21], dtype=torch.float64, requires_grad=True)
    weights = torch.rand(26, 25, generator=torch.Generator().manual_seed(0), dtype=torch.float64)

    def loss(s: torch.Tensor, w: torch.Tensor) -> torch.Tensor:
        return (render(s, w, 26, 25) * weights).sum()

    assert torch.autograd.gradcheck(loss, (seg, widths), eps=1e-6, atol=1e-5, rtol=1e-4)


def test_gradients_reach_every_input(render: Render, device: torch.device) -> None:
    seg = CURVE.to(device).requires_grad_(True)
    w = torch.tensor([2.5], dtype=torch.float64, device=device, requires_grad=True)
    render(seg, w, 64, 96).sum().backward()
    assert seg.grad is not None and torch.isfinite(seg.grad).all() and seg.grad.abs().sum() > 0
    assert w.grad is not None and w.grad.item() > 0  # wider stroke, more ink


DIAGONAL_END = (50.0 + 200 / math.sqrt(2), 100.3 + 200 / math.sqrt(2))


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
@pytest.mark.parametrize("end", [(250.0, 100.3), DIAGONAL_END])
def test_straight_stroke_area(dtype: torch.dtype, end: tuple[float, float], render: Render,
                              device: torch.device) -> None:
    """Area of a 200 px stroke of width 3 is 600 px² (+ round caps π·r², about 1.2%)."""
    img = render(line_segment((50.0, 100.3), end, dtype, device), 3.0, 300, 300)
    assert img.dtype == dtype
    assert abs(img.sum().item() - 600.0) / 600.0 < 0.02


def test_range_shape_and_device(render: Render, device: torch.device) -> None:
    seg = CURVE.float().to(device)
    img = render(seg, torch.tensor([4.0], device=device), 64, 96)
    assert img.shape == (64, 96) and img.device.type == device.type
    assert img.min() >= 0 and img.max() <= 1 and img.max() == 1


def test_device_matches_cpu(render: Render, device: torch.device) -> None:
    cpu = render_segments(CURVE, 3.0, 64, 96)
    dev = render(CURVE.to(device), 3.0, 64, 96).cpu()
    assert torch.allclose(cpu, dev, atol=1e-9)


def test_no_segments_gives_paper(render: Render, device: torch.device) -> None:
    img = render(torch.zeros(0, 4, 2, device=device), torch.zeros(0, device=device), 10, 12)
    assert img.shape == (10, 12) and (img == 0).all()


def test_off_canvas_segment_gives_paper_and_grad(render: Render, device: torch.device) -> None:
    seg = line_segment((-50.0, -20.0), (-10.0, -30.0), device=device).requires_grad_(True)
    img = render(seg, 3.0, 20, 20)
    assert (img == 0).all()
    img.sum().backward()
    assert seg.grad is not None and (seg.grad == 0).all()


def test_partly_off_canvas(render: Render, device: torch.device) -> None:
    img = render(line_segment((-50.0, 10.5), (10.0, 10.5), device=device), 3.0, 20, 20)
    assert abs(img.sum().item() - 3.0 * 10.0 - 0.5 * math.pi * 2.25) < 0.5


def test_zero_length_segment(render: Render, device: torch.device) -> None:
    seg = torch.tensor([[[10.2, 10.7]] * 4], device=device, requires_grad=True)
    img = render(seg, 3.0, 20, 20)
    assert abs(img.sum().item() - math.pi * 2.25) < 0.3  # a round dot
    img.sum().backward()
    assert seg.grad is not None and torch.isfinite(seg.grad).all()


def test_per_segment_widths(render: Render, device: torch.device) -> None:
    seg = torch.cat([line_segment((10.0, 20.5), (90.0, 20.5), device=device),
                     line_segment((10.0, 60.5), (90.0, 60.5), device=device)])
    img = render(seg, torch.tensor([2.0, 8.0], device=device), 80, 100)
    thin, thick = img[:40, 30:70].sum(0), img[40:, 30:70].sum(0)  # ink per column
    assert torch.allclose(thin, torch.full_like(thin, 2.0), atol=1e-4)
    assert torch.allclose(thick, torch.full_like(thick, 8.0), atol=1e-4)


def test_constant_radius_column_draws_that_width(render: Render) -> None:
    """A 3rd coordinate is the radius in px and the widths are then ignored: a constant
    radius 3.5 draws what width 7 draws in 2-D (varying radii: tests/test_varying_width.py)."""
    seg3 = torch.cat([CURVE, torch.full((1, 4, 1), 3.5, dtype=torch.float64)], 2)
    torch.testing.assert_close(render(seg3, 3.0, 64, 96), render(CURVE, 7.0, 64, 96),
                               atol=1e-12, rtol=0)


@pytest.mark.parametrize("bad", ["segments", "widths"])
def test_nan_raises_value_error(bad: str, render: Render) -> None:
    seg, w = CURVE.clone(), torch.tensor([3.0], dtype=torch.float64)
    (seg if bad == "segments" else w)[0, ...] = math.nan
    with pytest.raises(ValueError, match="NaN"):
        render(seg, w, 64, 96)


def test_bad_shape_raises_value_error() -> None:
    with pytest.raises(ValueError, match="shape"):
        render_segments(torch.zeros(3, 2), 3.0, 10, 10)


def test_split_curve_renders_the_same(render: Render) -> None:
    whole = render(CURVE, 3.0, 64, 96)
    left, right = split_cubic(CURVE, 0.37)
    l1, l2 = split_cubic(left, 0.5)
    split = render(torch.cat([l1, l2, right]), 3.0, 64, 96)
    assert (whole - split).abs().max() < 0.1
    assert (whole - split).abs().sum() < 0.01 * whole.sum()


def test_renderer_object_accepts_tensor_widths() -> None:
    img = RasterRenderer()(CURVE, torch.tensor([3.0], dtype=torch.float64), 64, 96)
    assert img.dtype == torch.float64


# --- the static path against the dynamic one ------------------------------------------------
def test_static_equals_dynamic_on_a_scribble(device: torch.device) -> None:
    """Image and gradients of the bench scene (750 segments) agree between the two paths."""
    seg = scribble_segments(n=300, size=120).double().to(device)
    widths = torch.full((300,), 3.0, dtype=torch.float64, device=device)
    weights = torch.rand(120, 120, generator=torch.Generator().manual_seed(2),
                         dtype=torch.float64).to(device)
    outs = []
    for fn in (render_segments, static_render):
        s, w = seg.clone().requires_grad_(True), widths.clone().requires_grad_(True)
        img = fn(s, w, 120, 120)
        (img * weights).sum().backward()
        outs.append((img.detach(), s.grad, w.grad))
    for got, ref in zip(*outs, strict=True):
        torch.testing.assert_close(got, ref, atol=1e-9, rtol=1e-9)


def test_small_budget_is_flagged_and_still_draws(device: torch.device) -> None:
    seg = scribble_segments(n=100, size=120).to(device)
    ref = render_segments(seg, 3.0, 120, 120)
    full = plan_budget(seg, 3.0, 120, 120)
    for small in (RasterBudget(full.pieces // 3, full.patch_x, full.patch_y),
                  RasterBudget(full.pieces, 3, 3)):
        img, overflow = render_segments_static(seg, 3.0, 120, 120, small)
        assert bool(overflow)
        assert 0.5 * float(ref.sum()) < float(img.sum()) <= 1.05 * float(ref.sum())
    img, overflow = render_segments_static(seg, 3.0, 120, 120, full)
    assert not bool(overflow) and torch.allclose(img, ref, atol=1e-5)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e30])
def test_unchecked_bad_values_neither_crash_nor_allocate(bad: float, device: torch.device) -> None:
    """Without checks, NaN/inf coordinates give a NaN image (the loss shows it), never a
    crash or an allocation sized from garbage; huge finite ones are drawn as far away."""
    seg = scribble_segments(n=50, size=64).to(device)
    budget = plan_budget(seg, 3.0, 64, 64)
    seg[7, 2, 0] = bad
    dynamic = render_segments(seg, 3.0, 64, 64, check=False)
    static, _ = render_segments_static(seg, 3.0, 64, 64, budget)
    for img in (dynamic, static):
        assert img.shape == (64, 64)
        assert bool(torch.isnan(img).all()) or math.isfinite(bad)


def test_session_plans_once_and_replans_on_overflow(device: torch.device) -> None:
    session = RasterSession(static=True)
    seg = scribble_segments(n=100, size=120).to(device)
    first = session(seg, 3.0, 120, 120)
    assert len(session.budgets) == 1 and not session.replan_if_needed()
    torch.testing.assert_close(first, render_segments(seg, 3.0, 120, 120))
    session(seg, 9.0, 120, 120)  # thicker: wider patches than planned
    assert session.replan_if_needed() and not session.budgets
    torch.testing.assert_close(session(seg, 9.0, 120, 120), render_segments(seg, 9.0, 120, 120))
    assert not session.replan_if_needed()


def test_plugin_session_is_static_off_the_cpu() -> None:
    renderer = inkmotion.plugin("renderer", "raster")
    assert not renderer.session("cpu").static
    assert renderer.session("cuda:0").static
    assert renderer.session("cpu", static=True).static


def test_sparse_backward_is_the_dense_graphs_gradient() -> None:
    """The rims-only backward pass (``sparse_backward``) gives the dense graph's image and
    gradients, a varying radius and exact ties included: a piece drawn twice shares each
    rim pixel's gradient between its two copies, as scatter_reduce's amax does."""
    g = torch.Generator().manual_seed(5)
    a = torch.rand(40, 2, generator=g, dtype=torch.float64) * 50 + 5
    b = a + torch.randn(40, 2, generator=g, dtype=torch.float64) * 2
    a, b = torch.cat((a, a[:3])), torch.cat((b, b[:3]))  # pieces 40..42 repeat 0..2
    r = torch.rand(43, generator=g, dtype=torch.float64) + 0.5
    r_end = torch.rand(43, generator=g, dtype=torch.float64) + 0.5
    r_end[40:] = r_end[:3]
    r[40:] = r[:3]
    c0, c1 = pixel_ranges(a, b, torch.maximum(r, r_end), 64, 64)
    patch = tuple((c1 - c0 + 1).amax(0).tolist())
    weights = torch.rand(64, 64, generator=g, dtype=torch.float64)
    outs = []
    for sparse in (False, True):
        leaves = [t.clone().requires_grad_(True) for t in (a, b, r, r_end)]
        img = capsule_coverage(*leaves[:3], c0, c1, patch, 64, 64, r_end=leaves[3],
                               sparse_backward=sparse)
        (img * weights).sum().backward()
        outs.append([img.detach()] + [t.grad for t in leaves])
    assert torch.equal(outs[0][0], outs[1][0])
    for got, ref in zip(outs[1][1:], outs[0][1:], strict=True):
        torch.testing.assert_close(got, ref, atol=1e-12, rtol=1e-10)
    sparse_grad_a = outs[1][1]
    assert sparse_grad_a[0].abs().sum() > 0
    torch.testing.assert_close(sparse_grad_a[40:], sparse_grad_a[:3], atol=0, rtol=0)
