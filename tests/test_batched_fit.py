"""Batched fits: several drawings in one optimisation give each drawing its own fit.

Each batched part against the per-drawing one it replaces (renderer canvases, stacked
multi-scale MSE, per-drawing smoothing, canvas and trace terms), then whole fit jobs run
together against the same jobs run alone, and the thread policy."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from inkmotion.fitting.losses import canvas_cost, canvas_costs, smoothing_cost, smoothing_costs
from inkmotion.image_losses.multiscale_mse import prepare_multiscale_mse, stack_multiscale_mse
from inkmotion.rendering.raster import (
    Canvases,
    plan_budget,
    render_segments,
    render_segments_static,
)
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.plan import MotorPlan


def _segments(n: int, w: float, h: float, seed: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return torch.rand(n, 4, 2, generator=g, dtype=torch.float64) * torch.tensor([w, h],
                                                                                dtype=torch.float64)


def _two_drawings() -> tuple[torch.Tensor, Canvases, torch.Tensor, torch.Tensor]:
    a, b = _segments(30, 120, 80, 1), _segments(20, 90, 100, 2)
    b[0] = torch.tensor([[80., 10.], [100., 20.], [130., 30.], [150., 40.]])  # past its edge
    image = torch.cat([torch.zeros(30, dtype=torch.long), torch.ones(20, dtype=torch.long)])
    return torch.cat([a, b]), Canvases(image, torch.tensor([[120, 80], [90, 100]]), 2), a, b


def test_canvases_render_each_drawing_exactly_as_alone_and_nothing_bleeds():
    segments, canvases, a, b = _two_drawings()
    stack = render_segments(segments, 3.0, 100, 120, check=False, canvases=canvases)
    assert stack.shape == (2, 100, 120)
    assert torch.equal(stack[0, :80, :120], render_segments(a, 3.0, 80, 120, check=False))
    assert torch.equal(stack[1, :100, :90], render_segments(b, 3.0, 100, 90, check=False))
    assert stack[0, 80:].abs().sum() == 0 and stack[1, :, 90:].abs().sum() == 0
    budget = plan_budget(segments, 3.0, 100, 120)
    static, _ = render_segments_static(segments, 3.0, 100, 120, budget, canvases=canvases)
    assert torch.equal(static, stack)


def test_a_nan_in_one_drawing_poisons_only_its_own_image():
    segments, canvases, _, _ = _two_drawings()
    segments[35, 1, 0] = float("nan")  # drawing 1
    stack = render_segments(segments, 3.0, 100, 120, check=False, canvases=canvases)
    assert not torch.isnan(stack[0]).any() and torch.isnan(stack[1]).all()


def test_the_stacked_multiscale_mse_is_each_drawings_own():
    g = torch.Generator().manual_seed(0)
    shapes = [(250, 350), (350, 242), (180, 350)]
    targets = [torch.rand(*s, generator=g, dtype=torch.float64) for s in shapes]
    images = [torch.rand(*s, generator=g, dtype=torch.float64) for s in shapes]
    losses = [prepare_multiscale_mse(t) for t in targets]
    page = torch.zeros(3, 350, 350, dtype=torch.float64)
    for k, (img, (h, w)) in enumerate(zip(images, shapes, strict=True)):
        page[k, :h, :w] = img
    together = stack_multiscale_mse(losses, 350, 350)(page)
    alone = torch.stack([fn(img) for fn, img in zip(losses, images, strict=True)])
    torch.testing.assert_close(together, alone, rtol=1e-12, atol=0)


def _plans(seed: int, paths: int) -> list[MotorPlan]:
    g = torch.Generator().manual_seed(seed)
    out = []
    for p in range(paths):
        m = 2 + p
        out.append(MotorPlan(points=torch.rand(m + 1, 2, generator=g, dtype=torch.float64) * 300
                             - 20, delta_t=0.1 + 0.8 * torch.rand(m, generator=g,
                                                                  dtype=torch.float64),
                             delta=torch.rand(m, generator=g, dtype=torch.float64) - 0.5,
                             ac=torch.full((m,), 0.05, dtype=torch.float64),
                             T=torch.full((m,), 0.3, dtype=torch.float64)))
    return out


@pytest.mark.parametrize("initial", [False, True])
@pytest.mark.parametrize("over", ["pooled", "drawing", "path"])
def test_smoothing_and_canvas_costs_per_drawing_are_each_drawings_own(over, initial):
    drawings = [_plans(1, 3), _plans(2, 1), _plans(3, 2)]
    union = PlanBatch.from_plans([p for d in drawings for p in d])
    layout = union.layout()
    t_end = torch.rand(len(layout.moves), dtype=torch.float64) + 1
    path_item = torch.repeat_interleave(torch.arange(3), torch.tensor([3, 1, 2]))
    # a fit's initial counts (fewer than the plans' own, as after edits that added targets)
    time_moves = (layout.moves - torch.tensor([1, 0, 1, 0, 1, 0])) if initial else None
    costs = smoothing_costs(union, t_end, 10.0, layout, over, path_item, 3, time_moves)
    sizes = torch.tensor([[250, 200], [300, 100], [120, 260]])
    point_item = torch.repeat_interleave(path_item, layout.moves + 1)
    canvas = canvas_costs(union.points, point_item, sizes, 3)
    start = 0
    for k, d in enumerate(drawings):
        own = PlanBatch.from_plans(d)
        ends = t_end[start:start + len(d)]
        start += len(d)
        own_moves = None if time_moves is None else time_moves[start - len(d):start]
        torch.testing.assert_close(costs[k], smoothing_cost(own, ends, 10.0, own.layout(), over,
                                                            own_moves))
        torch.testing.assert_close(canvas[k], canvas_cost(own.points, *sizes[k].tolist()))


def _fit_specs(words: list[str], steps: int) -> list:
    from inkmotion.jobs.spec import JobSpec

    return [JobSpec(kind="fit", inputs={"drawing": w}, params={"steps": steps, "size": 128},
                    record_every=0) for w in words]


def test_fit_jobs_run_together_report_each_its_own_fit(tmp_path):
    """Three fits in one batch against the same three alone: the same plan sizes, the
    same losses before the first step (float round-off), close fits after it (the stages'
    edits depend on the fit, so round-off can tip an edit: the goal is the same quality),
    each job's own artifacts, and a job whose input cannot be read fails alone."""
    from inkmotion.errors import InputError
    from inkmotion.jobs.shell import Together, run_job, run_jobs_together, unlike_the_record

    words = ["text:hi", "text:ok", "text:go"]
    specs = _fit_specs(words, 60)
    alone = [run_job(s, tmp_path / f"alone{k}") for k, s in enumerate(specs)]
    bad = tmp_path / "empty.svg"
    bad.write_text("<svg xmlns='http://www.w3.org/2000/svg'></svg>")
    jobs = [Together(s, tmp_path / f"together{k}") for k, s in enumerate(specs)]
    jobs.insert(1, Together(_fit_specs([str(bad)], 60)[0], tmp_path / "bad"))
    outcomes = run_jobs_together(jobs)
    assert isinstance(outcomes[1], InputError) and not (tmp_path / "bad").exists()
    together = [outcomes[0], *outcomes[2:]]
    for k, (one, many) in enumerate(zip(alone, together, strict=True)):
        assert many["batch"] == 4 and many["moves"] == one["moves"]
        for term, value in one["initial_loss"].items():
            # float32 sums of a few hundred terms in another order (index_add per drawing
            # against one sum): up to a few 1e-5 apart, the trace term's log-mean-exp of
            # its worst misses the furthest
            assert many["initial_loss"][term] == pytest.approx(value, rel=5e-5, abs=1e-6)
        assert abs(many["chamfer_mean_px"] - one["chamfer_mean_px"]) < 0.35
        saved = json.loads((tmp_path / f"together{k}" / "report.json").read_text())
        assert saved["chamfer_max_px"] == many["chamfer_max_px"]
        assert (tmp_path / f"together{k}" / "plan.json").is_file()
        # job.json says the plan came from a batch, and a rerun of it alone says why its
        # plan may differ (its batch-mates are not in it)
        job_json = json.loads((tmp_path / f"together{k}" / "job.json").read_text())
        assert job_json["batch"] == 4
        assert any("a worker's batch of 4 drawings" in s
                   for s in unlike_the_record(job_json, specs[k]))
        alone_json = json.loads((tmp_path / f"alone{k}" / "job.json").read_text())
        assert "batch" not in alone_json and unlike_the_record(alone_json, specs[k]) == []


def test_a_rerun_on_another_cpu_code_path_says_its_last_bits_may_differ():
    from inkmotion.jobs.shell import machine, unlike_the_record

    spec = _fit_specs(["text:a"], 3)[0]
    here = machine()["cpu_capability"]
    other = "DEFAULT" if here != "DEFAULT" else "AVX2"
    said = unlike_the_record({"machine": {"cpu_capability": other}}, spec)
    assert len(said) == 1 and f"torch's {other} CPU code path" in said[0]
    assert f"ATEN_CPU_CAPABILITY={other.lower()}" in said[0]
    assert unlike_the_record({"machine": {"cpu_capability": here}}, spec) == []


def test_report_records_the_thread_count(tmp_path):
    from inkmotion.jobs.shell import run_job

    report = run_job(_fit_specs(["text:a"], 3)[0], tmp_path / "one")
    assert report["threads"] == torch.get_num_threads()
    assert json.loads((Path(tmp_path) / "one" / "report.json").read_text())["threads"] >= 1


def test_balanced_chunks_fill_every_worker_and_keep_each_item_once(tmp_path):
    from inkmotion.benchmarks.quality import balanced_chunks

    sources = []
    for k in range(20):
        f = tmp_path / f"t{k}.json"
        f.write_text("x" * (100 * (k + 1)))
        sources.append(str(f))
    chunks = balanced_chunks(sources, jobs=2, batch=9)
    assert len(chunks) % 2 == 0 and all(len(c) <= 9 for c in chunks)
    assert sorted(i for c in chunks for i in c) == list(range(20))
    weights = [sum(k + 1 for k in c) for c in chunks]
    assert max(weights) - min(weights) <= 20  # each carries a similar share of the work
    assert balanced_chunks(sources, jobs=2, batch=1) == [[i] for i in range(20)]


def test_only_jobs_of_one_kind_and_the_same_parameters_batch():
    from inkmotion.jobs.shell import batchable
    from inkmotion.jobs.spec import JobSpec

    a, b = _fit_specs(["text:a", "text:b"], 10)
    assert batchable([a, b]) and not batchable([a])
    other = JobSpec(kind="fit", inputs={"drawing": "text:c"}, params={"steps": 11, "size": 128},
                    record_every=0)
    assert not batchable([a, other])
