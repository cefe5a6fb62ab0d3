"""``inkmotion bench`` explains what it prints: every figure's unit and meaning, a target
met or missed said in words, and a raster baseline of the project's own (nothing outside
the repository)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
import torch
from rich.console import Console

from inkmotion.benchmarks.dense_raster import render_dense
from inkmotion.benchmarks.figures import FIGURES, TARGETS, describe, show_value, verdict
from inkmotion.benchmarks.raster import bench_raster, scribble_segments
from inkmotion.benchmarks.suite import figures_record, print_figures
from inkmotion.rendering.raster import render_segments

PACKAGE = Path(__file__).resolve().parents[1] / "framework"


def test_a_missed_target_is_said_in_words() -> None:
    assert verdict(3.9, 60.0, "≤", "ms") == (True, "≤ 60 ms, met")
    assert verdict(11.2, 10.0, "≤", "ms") == (False, "≤ 10 ms, missed by 12 %")
    assert verdict(2.4, 3.0, "≥", "×") == (False, "≥ 3×, missed by 20 %")
    assert verdict(1.102, 1.1, "≤", "×") == (False, "≤ 1.1×, missed by 0.18 %")
    assert verdict(5, 0, "≤") == (False, "≤ 0, missed by 5")
    assert verdict(math.nan, 3.0, "≥", "×") == (False, "≥ 3×, not measured")
    assert show_value(math.nan, "ms") == "not measured"


def test_every_figure_and_target_is_described() -> None:
    assert set(TARGETS) <= set(FIGURES)
    for key in [*FIGURES, "fit_1000px_wall_s", "concurrent_4_fits_per_min",
                "batch_16_fits_per_min"]:
        unit, what = describe(key)
        assert what and what != "(no description)", key
    assert describe("fit_1000px_chamfer_max_px")[1].endswith("at 1000 px")
    assert describe("something_new") == ("", "(no description)")


def test_the_table_says_units_verdicts_and_what_each_figure_is() -> None:
    console = Console(width=80, record=True, color_system=None)
    figures = {"raster_ms": 3.99, "naive_ms": 1650.0, "speedup": 413.5,
               "kinematics_m150_ms": 11.2, "fit_input": "sample:tempt-1"}
    print_figures(figures, console, "inkmotion bench (cpu, 2 CPU threads)")
    text = console.export_text()
    assert all(len(line) <= 80 for line in text.splitlines())
    assert "3.99 ms" in text and "413.5×" in text and "≥ 3×, met" in text
    assert "≤ 10 ms, missed by 12 %" in text
    legend = text[text.index("What the figures are:"):]
    for key in figures:
        assert re.search(rf"^\s+{key}\s+\S", legend, re.M), key
    assert "dense baseline" in legend and "(no description)" not in text


def test_json_says_the_same_as_the_table() -> None:
    """``bench --json``: each figure's value, unit and meaning; a target's bound and
    verdict; a figure that could not be measured never counts as met."""
    record = figures_record({"raster_ms": 3.99, "kinematics_m150_ms": 11.2,
                             "speedup": math.nan, "fit_input": "sample:tempt-1"})
    assert record["raster_ms"]["unit"] == "ms" and record["raster_ms"]["met"] is True
    assert record["kinematics_m150_ms"] | {"what": ""} == {
        "value": 11.2, "unit": "ms", "what": "", "bound": 10.0, "cmp": "≤", "met": False,
        "verdict": "≤ 10 ms, missed by 12 %"}
    assert record["speedup"]["met"] is False
    assert "met" not in record["fit_input"] and record["fit_input"]["what"]


def test_the_dense_baseline_draws_the_renderers_image() -> None:
    seg = scribble_segments(n=60, size=64)
    widths = torch.full((60,), 3.0)
    s1, w1 = seg.clone().requires_grad_(True), widths.clone().requires_grad_(True)
    s2, w2 = seg.clone().requires_grad_(True), widths.clone().requires_grad_(True)
    dense, raster = render_dense(s1, w1, 64, 64), render_segments(s2, w2, 64, 64)
    assert dense.shape == (64, 64) and float(dense.detach().sum()) > 50
    torch.testing.assert_close(dense, raster, atol=1e-5, rtol=0)
    dense.sum().backward()
    raster.sum().backward()
    # the inner control points get the same gradient; at a joint of two segments the
    # gradient of a tie goes to one side or is split, so the joint's sum is compared
    torch.testing.assert_close(s1.grad[:, 1:3], s2.grad[:, 1:3], atol=1e-4, rtol=1e-4)
    joint1 = s1.grad[:-1, 3] + s1.grad[1:, 0]
    joint2 = s2.grad[:-1, 3] + s2.grad[1:, 0]
    torch.testing.assert_close(joint1, joint2, atol=1e-4, rtol=1e-4)


def test_the_raster_benchmark_measures_its_baseline() -> None:
    figures = bench_raster(repeats=1, naive_repeats=1)
    assert set(figures) == {"raster_ms", "naive_ms", "speedup", "raster_host_syncs"}
    assert all(math.isfinite(v) for v in figures.values())
    assert figures["naive_ms"] > figures["raster_ms"] > 0  # what the patches buy
    for key in figures:
        assert describe(key)[1] != "(no description)"


def test_the_fit_benchmark_takes_a_shipped_input() -> None:
    from inkmotion.benchmarks.fit import default_fit_input
    from inkmotion.errors import InkmotionError
    from inkmotion.kinds.read import read_input

    try:
        read_input("sample:tempt-1")
    except InkmotionError:  # the samples are not installed (yet): a word, never a path
        assert default_fit_input() == "text:inkmotion"
    else:
        assert default_fit_input() == "sample:tempt-1"


@pytest.mark.parametrize("needle", ["../shared", "shared/bench", "INKMOTION_SHARED_DIR",
                                    "naive_raster"])
def test_the_benchmarks_refer_to_nothing_outside_the_repository(needle: str) -> None:
    found = [str(p.relative_to(PACKAGE)) for p in (PACKAGE / "benchmarks").rglob("*.py")
             if needle in p.read_text(encoding="utf-8")]
    assert not found, found


def test_a_repeated_fit_benchmark_reports_the_median_and_the_spread() -> None:
    from inkmotion.benchmarks.fit import bench_fit

    figures = bench_fit("text:hi", steps=2, size=64, warm=True, repeat=3)
    low, mid, high = (figures[f"fit_64px_warm_wall_{k}"] for k in ("min_s", "s", "max_s"))
    assert 0 < low <= mid <= high
    for key in figures:
        assert describe(key)[1] != "(no description)", key
    once = bench_fit("text:hi", steps=2, size=64, warm=True)
    assert "fit_64px_warm_wall_s" in once and "fit_64px_warm_wall_min_s" not in once
