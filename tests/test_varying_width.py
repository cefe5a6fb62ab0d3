"""Varying stroke width (2.5D): plans (x, y, r) with r the stroke radius in px, end to end.

The 'raster' renderer draws segments (S, 4, 3) with the width following the radius
coordinate (both paths), the optimiser fits the radius with its own learning rate and
clamp, and the writers (SVG, trajectory.csv, plan.json, overlay, speed plot, recording)
take 3-D plans. 2-D behaviour is pinned by tests/test_raster.py and the v1-job
reproduction in tests/test_job_kinds.py; here only what 3-D adds.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import cv2
import pytest
import torch

import inkmotion
from inkmotion import Drawing, MotorPlan, bezier_segments
from inkmotion.benchmarks.raster import scribble_segments
from inkmotion.errors import InputError
from inkmotion.events import RunContext
from inkmotion.fitting.objective import Objective, Weights
from inkmotion.fitting.optimise import OptimiserSettings, optimise
from inkmotion.outputs import write_overlay, write_speed_plot, write_svg, write_trajectory_csv
from inkmotion.plugin_host.protocols import Reference
from inkmotion.profiling import count_host_syncs
from inkmotion.recording import RerunRecorder, entity_paths
from inkmotion.rendering.raster import plan_budget, render_segments, render_segments_static
from inkmotion.sigma_lognormal.batch import PlanBatch

#: the authors' objective and Adam settings (the engine keeps no defaults of its own), with
#: the generation kinds' radius settings
AUTHORS = Weights(lambda_smooth=20.0, w_image=200.0, w_sigma=50.0, w_canvas=1.0,
                  samples_per_move=5, smooth_over="path", w_trace=0.0, w_floor=0.0)


def settings_of(steps: int, lr_radius: float = 0.1,
                radius_range: tuple[float, float] = (0.5, 4.0)) -> OptimiserSettings:
    return OptimiserSettings(steps, lr_points=2.0, lr_delta_t=0.05, lr_delta=0.1, lr_ac=0.0,
                             lr_final=0.1, lr_radius=lr_radius, radius_range=radius_range)

SVG = "{http://www.w3.org/2000/svg}"
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


def tapered_line(p0: tuple[float, float], p1: tuple[float, float], r0: float, r1: float,
                 dtype: torch.dtype = torch.float32,
                 device: torch.device | str = "cpu") -> torch.Tensor:
    """A straight cubic (1, 4, 3) with control points at the thirds: x, y and r linear in u."""
    a = torch.tensor((*p0, r0), dtype=dtype)
    b = torch.tensor((*p1, r1), dtype=dtype)
    return torch.stack([a, a + (b - a) / 3, a + 2 * (b - a) / 3, b])[None].to(device)


# --- the renderer ------------------------------------------------------------------------------
def test_width_follows_the_radius(render: Render, device: torch.device) -> None:
    """A horizontal stroke whose radius grows from 1 to 4 px over 100 px: the ink of every
    column (the width of a vertical cut, Σ_k clamp(r + ½ − |k|, 0, 1) = 2r for a centre on a
    pixel centre) is 2·r(x) within 0.02 px, away from the round caps."""
    seg = tapered_line((10.0, 30.5), (110.0, 30.5), 1.0, 4.0, device=device)
    img = render(seg, 3.0, 64, 128)
    cols = torch.arange(16, 105)  # column centres c + ½, 6 px from either cap
    measured = img[:, cols].sum(0).cpu()  # (C,) px of ink across each vertical cut
    expected = 2 * (1.0 + 3.0 * (cols + 0.5 - 10.0) / 100.0)
    torch.testing.assert_close(measured, expected.float(), atol=0.02, rtol=0)
    # and as ink pixels (coverage > ½) across a cut: 2r ± 1 px
    left, right = ((img[:, c].cpu() > 0.5).sum() for c in (20, 100))
    assert abs(int(left) - 2 * 1.3) <= 1 and abs(int(right) - 2 * 3.7) <= 1


def test_widths_are_ignored_for_3d_segments(render: Render) -> None:
    seg = tapered_line((10.0, 30.5), (110.0, 30.5), 1.0, 4.0, dtype=torch.float64)
    ref = render(seg, 3.0, 64, 128)
    assert torch.equal(render(seg, torch.tensor([9.0], dtype=torch.float64), 64, 128), ref)
    nan = render_segments(seg, math.nan, 64, 128)  # not checked: ignored
    assert torch.equal(nan, ref)


def test_constant_radius_equals_a_2d_width(render: Render, device: torch.device) -> None:
    seg3 = scribble_segments(n=60, size=96).double().to(device)
    seg3 = torch.cat((seg3, torch.full_like(seg3[..., :1], 2.25)), 2)  # (S, 4, 3)
    torch.testing.assert_close(render(seg3, 1.0, 96, 96), render(seg3[..., :2], 4.5, 96, 96),
                               atol=1e-12, rtol=0)


def test_gradients_reach_the_radius(render: Render, device: torch.device) -> None:
    seg = tapered_line((10.0, 30.5), (110.0, 40.5), 1.0, 4.0, torch.float64, device)
    seg = seg.requires_grad_(True)
    render(seg, 3.0, 64, 128).sum().backward()
    grad = seg.grad
    assert grad is not None and bool(torch.isfinite(grad).all())
    assert bool((grad[..., 2] > 0).all())  # every control radius adds ink
    assert float(grad[..., :2].abs().sum()) > 0


def test_gradcheck_with_radius(render: Render) -> None:
    seg = torch.tensor([[[4.31, 6.17, 1.13], [9.73, 2.29, 2.71], [14.58, 17.61, 1.94],
                         [21.13, 11.47, 3.02]],
                        [[3.57, 19.81, 0.83], [7.12, 21.33, 1.37], [11.91, 20.62, 2.46],
                         [16.44, 22.05, 1.58]]], dtype=torch.float64, requires_grad=True)
    weights = torch.rand(26, 25, generator=torch.Generator().manual_seed(0), dtype=torch.float64)

    def loss(s: torch.Tensor) -> torch.Tensor:
        return (render(s, 3.0, 26, 25) * weights).sum()

    assert torch.autograd.gradcheck(loss, (seg,), eps=1e-6, atol=1e-5, rtol=1e-4)


def test_static_equals_dynamic_in_3d(device: torch.device) -> None:
    """Image and gradients (radius included) of a scribble with random radii agree."""
    g = torch.Generator().manual_seed(3)
    seg = scribble_segments(n=200, size=120).double()
    radii = 0.5 + 3.5 * torch.rand(seg.shape[0], 4, 1, generator=g, dtype=torch.float64)
    seg = torch.cat((seg, radii), 2).to(device)  # (S, 4, 3)
    weights = torch.rand(120, 120, generator=g, dtype=torch.float64).to(device)
    outs = []
    for fn in (render_segments, static_render):
        s = seg.clone().requires_grad_(True)
        img = fn(s, 3.0, 120, 120)
        (img * weights).sum().backward()
        outs.append((img.detach(), s.grad))
    for got, ref in zip(*outs, strict=True):
        torch.testing.assert_close(got, ref, atol=1e-9, rtol=1e-9)
    assert float(outs[0][1][..., 2].abs().sum()) > 0


def test_negative_radii_clamp_to_zero_and_are_rejected_when_checked(device: torch.device
                                                                     ) -> None:
    neg = tapered_line((10.0, 30.5), (110.0, 30.5), -2.0, -2.0, device=device)
    zero = tapered_line((10.0, 30.5), (110.0, 30.5), 0.0, 0.0, device=device)
    budget = plan_budget(zero, 3.0, 64, 128)
    for img in (render_segments(neg, 3.0, 64, 128, check=False),
                render_segments_static(neg, 3.0, 64, 128, budget)[0]):
        assert torch.equal(img, render_segments(zero, 3.0, 64, 128))
    for fn in (render_segments, static_render):
        with pytest.raises(ValueError, match="radii"):
            fn(neg, 3.0, 64, 128)


def test_renderer_plugin_and_session_take_3d(device: torch.device) -> None:
    seg = tapered_line((10.0, 30.5), (110.0, 30.5), 1.0, 4.0, device=device)
    renderer = inkmotion.plugin("renderer", "raster")
    ref = renderer(seg, 3.0, 64, 128)
    session = renderer.session(device, static=True)
    torch.testing.assert_close(session(seg, 3.0, 64, 128), ref)
    assert not session.replan_if_needed()
    thick = seg.clone()
    thick[..., 2] = 9.0  # wider patches than planned: flagged, then replanned
    session(thick, 3.0, 64, 128)
    assert session.replan_if_needed()
    torch.testing.assert_close(session(thick, 3.0, 64, 128), renderer(thick, 3.0, 64, 128))


# --- the fit --------------------------------------------------------------------------------
CANVAS = (128, 128)
STROKE = [[20.0, 30.0], [60.0, 40.0], [95.0, 70.0], [100.0, 105.0]]


def _objective(target: torch.Tensor, static: bool | None = None) -> Objective:
    """Objective with the 'raster' renderer and the 'mse' loss, as the fit kind wires it."""
    loss = inkmotion.plugin("image-loss", "mse").prepare(Reference(image=target))
    return Objective(inkmotion.plugin("renderer", "raster"), {"mse": loss}, CANVAS, AUTHORS,
                     static=static)


def _target(device: torch.device, width: float = 8.0) -> torch.Tensor:
    """The 2-D stroke through STROKE drawn ``width`` px wide (H, W)."""
    plan = MotorPlan.from_points(STROKE, device=device)
    with torch.no_grad():
        seg = bezier_segments(plan)
        return inkmotion.plugin("renderer", "raster")(seg, width, CANVAS[1], CANVAS[0])


def test_fit_grows_the_radius_toward_the_target(device: torch.device) -> None:
    """Initial radius 1 px against a target 8 px wide (radius 4): the mean radius rises
    past 3 px (toward 4), every radius stays in radius_range, and the image loss falls."""
    plan = MotorPlan.from_points(STROKE, device=device).with_radius(1.0)
    settings = settings_of(80)
    fit = optimise([plan], _objective(_target(device)), settings)
    r = fit.plans[0].points[:, 2]
    lo, hi = settings.radius_range
    assert float(r.min()) >= lo and float(r.max()) <= hi
    assert float(r.mean()) > 3.0, r
    assert fit.final_terms["mse"] < 0.5 * fit.initial_terms["mse"]
    assert fit.plans[0].dim == 3 and fit.rendered.shape == (CANVAS[1], CANVAS[0])


def test_radius_clamp_holds(device: torch.device) -> None:
    plan = MotorPlan.from_points(STROKE, device=device).with_radius(1.0)
    settings = settings_of(30, lr_radius=0.3, radius_range=(0.75, 2.0))
    r = optimise([plan], _objective(_target(device)), settings).plans[0].points[:, 2]
    assert float(r.min()) >= 0.75 and float(r.max()) == 2.0  # pushed up to the clamp


def test_radius_settings_leave_2d_fits_alone() -> None:
    """A 2-D plan keeps one points leaf: the radius settings change nothing, bit for bit."""
    plan = MotorPlan.from_points(STROKE)
    base = settings_of(10)
    other = dataclasses.replace(base, lr_radius=5.0, radius_range=(3.0, 3.5))
    fits = [optimise([plan], _objective(_target(torch.device("cpu"), 3.0)), s).plans[0]
            for s in (base, other)]
    assert fits[0].dim == 2
    for k in ("points", "delta_t", "delta", "ac"):
        assert torch.equal(getattr(fits[0], k), getattr(fits[1], k))


def test_3d_fit_step_makes_no_host_sync(device: torch.device) -> None:
    """The static (GPU) objective on a 3-D batch: no host synchronisation after planning."""
    plan = MotorPlan.from_points(STROKE, device=device).with_radius(1.5)
    objective = _objective(_target(device), static=True)
    src = PlanBatch.from_plans([plan])
    xy, r = (src.points[:, :2].clone().requires_grad_(True),
             src.points[:, 2:].clone().requires_grad_(True))

    def step() -> None:
        batch = PlanBatch(torch.cat((xy, r), 1), src.delta_t, src.delta, src.ac, src.T,
                          src.moves, src.widths)
        objective(batch).total.backward()

    step()
    with count_host_syncs() as log:
        step()
    assert log.count == 0, log.summary()
    assert r.grad is not None and bool(torch.isfinite(r.grad).all())
    assert float(r.grad.abs().sum()) > 0


# --- the plan and the writers ---------------------------------------------------------------
def _plan3() -> MotorPlan:
    """A 3-D plan whose radius grows from 1 to 4 px along the stroke."""
    pts = [[*p, 1.0 + i] for i, p in enumerate(STROKE)]
    return MotorPlan.from_points(pts, dtype=torch.float64)


def test_with_radius() -> None:
    plan = MotorPlan.from_points(STROKE, dtype=torch.float64)
    lifted = plan.with_radius(2.5)
    assert lifted.dim == 3 and torch.equal(lifted.points[:, :2], plan.points)
    assert torch.equal(lifted.points[:, 2], torch.full((4,), 2.5, dtype=torch.float64))
    assert lifted.delta_t is plan.delta_t and lifted.width == plan.width
    assert lifted.with_radius(7.0) is lifted
    with pytest.raises(InputError, match="radius"):
        plan.with_radius(-1.0)


def test_plan_json_round_trips_3d(tmp_path: Path) -> None:
    plans = [_plan3(), MotorPlan.from_points(STROKE, dtype=torch.float64).with_radius(2.0)]
    Drawing((128.0, 128.0), plans).save(tmp_path / "plan.json")
    back = Drawing.load(tmp_path / "plan.json").plans
    for a, b in zip(plans, back, strict=True):
        assert b.dim == 3
        torch.testing.assert_close(b.points.double(), a.points, atol=1e-6, rtol=0)


def test_svg_of_a_3d_plan_has_brush_outlines_and_centre_lines(tmp_path: Path) -> None:
    """A drawing with a 2.5D trajectory is written as two layers: filled outlines (the
    region each brush covers, the 2-D trajectory with its constant radius) and centre
    lines; the outline's area matches the ink the 'raster' renderer draws within 3 %."""
    from shapely import Polygon

    from inkmotion.outputs.brush_svg import brush_outline

    plans = [_plan3(), MotorPlan.from_points(STROKE, dtype=torch.float64, width=5.0)]
    segs = [bezier_segments(p).detach() for p in plans]
    out = tmp_path / "drawing.svg"
    write_svg(out, segs, [p.width for p in plans], CANVAS)
    root = ET.parse(out).getroot()
    outlines, centres = root.findall(f"{SVG}g")
    assert outlines.get("id") == "outlines" and centres.get("id") == "centre-lines"
    assert outlines.get("fill-rule") == "evenodd" and outlines.get("stroke") == "none"
    assert [p.get("id") for p in outlines] == ["outline0", "outline1"]
    assert all(p.get("d").startswith("M ") and p.get("d").endswith("Z") for p in outlines)
    assert [p.get("d").count("C ") for p in centres] == [len(s) for s in segs]
    # the filled region of the first path, read back from the SVG, has the brush's area
    ring = outlines[0].get("d").split(" Z")[0].replace("M ", "").replace("L ", "").split()
    xy = [(float(ring[i]), float(ring[i + 1])) for i in range(0, len(ring), 2)]
    region = brush_outline(segs[0])
    assert Polygon(xy).area == pytest.approx(Polygon(region.exterior).area, rel=1e-3)
    raster = inkmotion.plugin("renderer", "raster")
    width, height = (int(c) for c in CANVAS)
    ink = float(raster(segs[0].float(), torch.ones(len(segs[0])), height, width).sum())
    assert region.area == pytest.approx(ink, rel=0.03)


def test_trajectory_csv_has_the_radius(tmp_path: Path) -> None:
    out = tmp_path / "trajectory.csv"
    write_trajectory_csv(out, [_plan3()], samples_per_move=10)
    rows = list(csv.DictReader(out.open()))
    assert "r" in rows[0] and len(rows) == 31
    r = [float(row["r"]) for row in rows]
    assert r[0] == pytest.approx(1.0, abs=0.01) and r[-1] == pytest.approx(4.0, abs=0.01)
    assert all(0.99 <= v <= 4.01 for v in r)


def test_overlay_and_speed_plot_take_3d(tmp_path: Path) -> None:
    plan = _plan3()
    img = render_segments(bezier_segments(plan).detach(), 3.0, *CANVAS)
    write_overlay(tmp_path / "overlay.png", img, img, traces=[plan.points.numpy()],
                  positions=[plan.points])
    write_speed_plot(tmp_path / "speed.png", [plan])
    for name in ("overlay.png", "speed.png"):
        assert cv2.imread(str(tmp_path / name)) is not None


def test_recording_of_a_3d_fit(tmp_path: Path) -> None:
    recorder = RerunRecorder(tmp_path / "recording.rrd", image_every=5)
    target = _target(torch.device("cpu"))
    recorder.on_start(RunContext(None, tmp_path, 6, CANVAS, target,
                                 [torch.tensor(STROKE).numpy()]))
    plan = MotorPlan.from_points(STROKE).with_radius(1.0)
    optimise([plan], _objective(target), settings_of(6), recorder)
    recorder.on_end({})
    paths = entity_paths(tmp_path / "recording.rrd")
    assert {"/strokes/0/trajectory", "/strokes/0/targets", "/speed/0"} <= paths


def test_vpype_reads_the_outlines_and_the_centre_lines_as_two_layers(tmp_path: Path) -> None:
    vpype = pytest.importorskip("vpype")
    segs = [bezier_segments(_plan3()).detach()]
    out = tmp_path / "drawing.svg"
    write_svg(out, segs, [3.0], CANVAS)
    doc = vpype.read_multilayer_svg(str(out), quantization=0.1)
    assert len(doc.layers) == 2
    names = sorted(doc.layers[k].property("vp_name") for k in doc.layers)
    assert names == ["centre lines", "outlines"]
    lengths = {doc.layers[k].property("vp_name"): doc.layers[k].length() for k in doc.layers}
    centre = float(torch.linalg.vector_norm(torch.diff(torch.tensor(STROKE), dim=0),
                                            dim=1).sum())
    assert lengths["centre lines"] == pytest.approx(centre, rel=0.1)
    assert lengths["outlines"] > 2 * lengths["centre lines"] * 0.9  # around both sides
