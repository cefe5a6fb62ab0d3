"""plan.json round trip and errors; Hermite Bézier segments."""

from __future__ import annotations

import json
import math

import pytest
import torch

from inkmotion import Drawing, MotorPlan, bezier_segments, kinematics
from inkmotion.errors import InputError
from inkmotion.geometry.bezier import batch_bezier_segments
from inkmotion.sigma_lognormal import PlanBatch

F64 = torch.float64


def sample_plan(dim: int = 2) -> MotorPlan:
    g = torch.Generator().manual_seed(0)
    pts = torch.cumsum(torch.randn(7, dim, generator=g, dtype=F64) * 20, 0)
    if dim == 3:
        pts[:, 2] = 2.0
    plan = MotorPlan.from_points(pts, dtype=F64, width=2.5)
    plan.delta.uniform_(-1, 1, generator=g)
    plan.delta_t.uniform_(0.2, 0.9, generator=g)
    return plan


@pytest.mark.parametrize("dim", [2, 3])
def test_plan_round_trip(tmp_path, dim: int) -> None:
    plan = sample_plan(dim)
    plan.save(tmp_path / "plan.json", canvas=(300, 200))
    loaded = MotorPlan.load(tmp_path / "plan.json")
    torch.testing.assert_close(loaded.points.double(), plan.points, atol=1e-4, rtol=0)
    assert loaded.width == 2.5
    assert float(loaded.end_time) == pytest.approx(float(plan.end_time), rel=1e-5)
    data = json.loads((tmp_path / "plan.json").read_text())
    assert data["version"] == 1 and data["canvas"] == {"width": 300, "height": 200}
    assert set(data["paths"][0]) == {"points", "delta_t", "delta", "ac", "T", "width"}


@pytest.mark.parametrize("content, fragment", [
    ("{not json", "is not valid JSON"),
    ('{"version": 7, "canvas": {"width": 1, "height": 1}, "paths": []}', "version"),
    ('{"version": 1, "canvas": {"width": 10, "height": 10}, "paths": [{"points": [[0, 0]]}]}',
     r"paths\[0\] has 1 point; a path needs its start and at least one target"),
    ('[1, 2]', "its top level is a list"),
    ('{"spec": {}, "versions": {}, "seed": 0}', "is a job.json, not a plan.json"),
    ('{"kind": "fit", "wall_s": 3.1, "paths": 2, "canvas": {}}', "is a report.json"),
    ('{"traces": [[[0, 0], [1, 1]]]}', "is an input.json"),
    ('{"version": 1, "canvas": {"width": 10, "height": 10}, "paths": []}', "at least one path"),
    ('{"version": 1, "canvas": {"width": 10, "height": 10}, "paths": [{"points": [[0, 0], '
     '[NaN, 1]], "delta_t": [1], "delta": [0], "ac": [0.01], "T": [0.8]}]}', "NaN"),
    # finite, and huge: overflowed evaluate's timings into a traceback
    ('{"version": 1, "canvas": {"width": 1e308, "height": 10}, "paths": [{"points": [[0, 0], '
     '[1, 1]], "delta_t": [1], "delta": [0], "ac": [0.01], "T": [0.8]}]}',
     "its canvas is 1e.308 × 10 px, over the 100000 px"),
    ('{"version": 1, "canvas": {"width": 10, "height": 10}, "paths": [{"points": [[0, 0], '
     '[1e30, 1]], "delta_t": [1], "delta": [0], "ac": [0.01], "T": [0.8]}]}',
     r"paths\[0\] has a target 1e\+30 px from the origin, over 100 times its 10 × 10-px"),
    ('{"version": 1, "canvas": {"width": 10, "height": 10}, "paths": [{"points": [[0, 0], '
     '[1e300, 1]], "delta_t": [1], "delta": [0], "ac": [0.01], "T": [0.8]}]}',
     "beyond a 32-bit float's 3.4e38"),
])
def test_bad_plan_files(tmp_path, content: str, fragment: str) -> None:
    path = tmp_path / "plan.json"
    path.write_text(content)
    with pytest.raises(InputError, match=fragment) as info:
        Drawing.load(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize("field, value, fragment", [
    ("T", -1.0, r"paths\[0\]\.T\[1\] is -1, but it is a duration, positive"),
    ("ac", 1.5, r"\.ac\[1\] is 1\.5, but it is the lognormal's shape Ac, between 0 and 1"),
    ("delta_t", -5.0, r"\.delta_t\[1\] is -5, but it is an overlap"),
    ("delta", 100.0, r"\.delta\[1\] is 100, but it is an arc's turn"),
    ("delta", 2 * math.pi, r"\.delta\[1\] is 6\.28319, but it is an arc's turn δ, less than 2π"),
    ("width", -3.0, r"\.width is -3, but a pen's width is 0 or more"),
    ("delta_t", [0.5], r"\.delta_t has 1 values for its 2 sub-movements"),
])
def test_a_plan_whose_values_are_no_movement_is_refused(tmp_path, field: str, value: object,
                                                       fragment: str) -> None:
    """An edited plan.json with a negative duration, a shape outside (0, 1), onsets that go
    back, an arc of 16 turns or a negative pen: every command that reads plans (render,
    plot, simulate, evaluate) refuses it in one sentence naming the value, instead of a
    NaN error deep inside (or an evaluation that runs for hours)."""
    path = tmp_path / "plan.json"
    plan = {"points": [[0, 0], [5, 5], [9, 2]], "delta_t": [1.0, 0.5], "delta": [0.1, 0.2],
            "ac": [0.01, 0.01], "T": [0.8, 0.8], "width": 3.0}
    if isinstance(value, list):
        plan[field] = value
    elif field == "width":
        plan[field] = value
    else:
        plan[field][1] = value
    path.write_text(json.dumps({"version": 1, "canvas": {"width": 10, "height": 10},
                                "paths": [plan]}))
    with pytest.raises(InputError, match=fragment) as info:
        Drawing.load(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and message.endswith(".")


def test_missing_plan_index(tmp_path) -> None:
    sample_plan().save(tmp_path / "p.json")
    with pytest.raises(InputError, match="no path 3"):
        MotorPlan.load(tmp_path / "p.json", index=3)


def on(plan: MotorPlan, device: torch.device) -> MotorPlan:
    return MotorPlan(*(getattr(plan, k).to(device) for k in ("points", "delta_t", "delta", "ac",
                                                              "T")), plan.width)


@pytest.mark.parametrize("dim", [2, 3])
def test_bezier_reproduces_samples_and_tangents(dim: int, device: torch.device) -> None:
    plan = on(sample_plan(dim), device)
    seg = bezier_segments(plan)  # (5m, 4, D)
    n = 5 * plan.m
    assert seg.shape == (n, 4, dim)
    dt = float(plan.end_time) / n
    t = torch.arange(n + 1, dtype=F64, device=device) * dt
    x, v, _ = kinematics(plan, t)
    torch.testing.assert_close(seg[:, 0], x[:-1])
    torch.testing.assert_close(seg[:, 3], x[1:])
    # B'(0) = 3 (P1 − P0) in the segment parameter u = (t − t_k)/dt, so dx/dt = 3 (P1 − P0)/dt
    torch.testing.assert_close(3 * (seg[:, 1] - seg[:, 0]) / dt, v[:-1])
    torch.testing.assert_close(3 * (seg[:, 3] - seg[:, 2]) / dt, v[1:])
    # Hermite accuracy: the curve's midpoint is near the trajectory's midpoint
    mid = 0.125 * seg[:, 0] + 0.375 * seg[:, 1] + 0.375 * seg[:, 2] + 0.125 * seg[:, 3]
    x_mid = kinematics(plan, t[:-1] + dt / 2).positions
    length = (plan.points[1:] - plan.points[:-1]).norm(dim=1).sum()
    assert float((mid - x_mid).norm(dim=1).max()) < 0.01 * float(length)


def test_bezier_custom_sample_count() -> None:
    plan = sample_plan()
    assert bezier_segments(plan, n=17).shape == (17, 4, 2)


def test_batch_segments_stop_at_pen_lifts(device: torch.device) -> None:
    """Segments of a batch are each path's own segments, none joining two paths."""
    plans = [on(sample_plan(), device), on(sample_plan(3), device)]
    batch = PlanBatch.from_plans([MotorPlan(p.points[:, :2], p.delta_t, p.delta, p.ac, p.T)
                                  for p in plans])
    layout = batch.layout()
    seg = batch_bezier_segments(batch, layout)
    assert seg.shape == (layout.n_segments, 4, 2) == (5 * 12, 4, 2)
    parts = torch.split(seg, [5 * p.m for p in plans])
    for plan, part in zip(batch.to_plans(), parts, strict=True):
        torch.testing.assert_close(part, bezier_segments(plan))
    assert layout.segment_path.tolist() == [0] * 30 + [1] * 30


def test_end_time_is_differentiable() -> None:
    plan = sample_plan()
    plan.delta_t.requires_grad_(True)
    plan.end_time.backward()
    g = plan.delta_t.grad
    # T_end = Σ_{i≥2} Δt_i·T_i + T: ∂/∂Δt_1 = 0, ∂/∂Δt_i = T_i
    assert float(g[0]) == 0.0
    torch.testing.assert_close(g[1:], plan.T[1:])
    assert math.isfinite(float(plan.end_time.detach()))


def test_a_plan_file_nested_too_deeply_is_one_sentence(tmp_path):
    """Fuzzing: a plan.json of 100 000 nested lists raised RecursionError out of evaluate
    and plot."""
    deep = tmp_path / "plan.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InputError, match="nested too deeply to be a plan"):
        Drawing.load(deep)
