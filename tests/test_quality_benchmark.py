"""The quality benchmark (``inkmotion benchmark``): a real run of two words and a missing file
in two worker processes through the command, then the pieces (names, parameters, aggregate,
the optional figures hook) on their own."""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from inkmotion.benchmarks import quality as bm
from inkmotion.errors import InkmotionError, InputError, SpecError


@pytest.fixture(scope="module")
def bench_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """``inkmotion benchmark text:hi text:ok MISSING --jobs 2 --steps 10 --size 96``."""
    from inkmotion.cli.benchmark import register

    app = typer.Typer()
    register(app)
    app.command("unused")(lambda: None)  # two commands: typer keeps `benchmark` as a name
    out = tmp_path_factory.mktemp("bench")
    missing = str(out / "missing.json")
    result = CliRunner().invoke(app, ["benchmark", "text:hi", "text:ok", missing, "--out",
                                      str(out), "--jobs", "2", "--steps", "10", "--size", "96"])
    return out, result


def test_items_have_finite_figures_and_a_failure_is_one_row(bench_run: tuple) -> None:
    out, result = bench_run
    assert result.exit_code == 1, result.output  # written, but one item failed
    summary = json.loads((out / "summary.json").read_text())
    rows = {r["item"]: r for r in summary["items"]}
    assert list(rows) == ["text-hi", "text-ok", "missing"]
    for name in ("text-hi", "text-ok"):
        row = rows[name]
        assert row["status"] == "ok"
        assert row["steps"] == 10 and row["moves"] > 0
        for key in ("chamfer_mean_px", "chamfer_max_px", "iou", "t_end_ratio",
                    "delta_t_at_clamp", "fit_s", "wall_s"):
            assert math.isfinite(row[key]), (name, key)
        assert 0 < row["iou"] <= 1 and 0 <= row["delta_t_at_clamp"] <= 1
        assert (out / name / "plan.json").is_file() and (out / name / "overlay.png").is_file()
    failed = rows["missing"]
    assert failed["status"] == "failed"
    assert "missing.json" in failed["error"] and "\n" not in failed["error"]
    assert not (out / "missing").exists()
    totals = summary["totals"]
    assert (totals["items"], totals["succeeded"], totals["failed"]) == (3, 2, 1)
    assert summary["aggregate"]["iou"]["n"] == 2
    assert "Chamfer mean" in result.output and "missing.json" in result.output


def test_summary_files_and_thumbnails(bench_run: tuple) -> None:
    out, _ = bench_run
    for name in bm.SUMMARY_FILES:
        assert (out / name).is_file(), name
    csv_lines = (out / "summary.csv").read_text().splitlines()
    assert len(csv_lines) == 4 and csv_lines[0].startswith("item,source,status,moves")
    md = (out / "summary.md").read_text()
    assert md.index("## Aggregate") < md.index("## Items")
    page = (out / "summary.html").read_text()
    images = re.findall(r'<img src="([^"]+)"', page)
    assert len(images) == 4  # overlay and speed of the two fitted items
    for src in images:
        assert not src.startswith(("/", "http")) and (out / src).is_file(), src
    assert "http" not in page  # self-contained: nothing loaded from elsewhere


def test_item_names_are_distinct_and_safe() -> None:
    names = bm.item_names(["text:hello", "a/49867.json", "b/49867.json", "text:a b"])
    assert names == ["text-hello", "49867", "49867-2", "text-a_b"]


def test_params_and_plugin_options() -> None:
    assert bm.parse_param("lambda_smooth=40") == ("lambda_smooth", 40)
    assert bm.parse_param("initialiser=line") == ("initialiser", "line")
    with pytest.raises(SpecError):
        bm.parse_param("no-equals-sign")
    params = bm.fit_params(10, None, {"initialiser.threshold": 20, "w_image": 100.0})
    assert params == {"initialiser": {"name": "dce", "threshold": 20}, "w_image": 100.0,
                      "steps": 10}
    with pytest.raises(SpecError):
        bm.fit_params(None, None, {"steps.x": 1})


def test_a_bad_parameter_fails_before_anything_runs(tmp_path: Path) -> None:
    with pytest.raises(SpecError):
        bm.run_benchmark(["text:hi"], tmp_path / "b", params={"no_such_param": 1})
    assert not (tmp_path / "b").exists()


def test_folders_expand_to_their_drawings(tmp_path: Path) -> None:
    (tmp_path / "b.gml").write_text("")
    (tmp_path / "a.json").write_text("")
    (tmp_path / "notes.txt").write_text("")
    (tmp_path / "scan.PNG").write_bytes(b"")  # a picture of a drawing (checked when read)
    assert bm.expand_inputs([str(tmp_path), "text:x"]) == [
        str(tmp_path / "a.json"), str(tmp_path / "b.gml"), str(tmp_path / "scan.PNG"),
        "text:x"]
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError):
        bm.expand_inputs([str(empty)])


def test_aggregate_skips_failures_and_non_finite_values() -> None:
    rows = [{"item": "a", "source": "a", "status": "ok", "iou": 0.5, "moves": 10},
            {"item": "b", "source": "b", "status": "ok", "iou": float("nan"), "moves": 20},
            {"item": "c", "source": "c", "status": "failed", "error": "x", "iou": 0.0}]
    summary = bm.summarise(rows, wall_s=1.0)
    assert summary["aggregate"]["iou"] == {"n": 1, "mean": 0.5, "median": 0.5, "min": 0.5,
                                           "max": 0.5}
    assert summary["aggregate"]["moves"]["mean"] == 15
    assert summary["totals"]["failed"] == 1


def test_words_get_speed_peaks_and_evaluation_ratios(bench_run: tuple) -> None:
    out, _ = bench_run
    rows = {r["item"]: r for r in json.loads((out / "summary.json").read_text())["items"]}
    for name in ("text-hi", "text-ok"):
        row = rows[name]
        assert "motion_error" not in row, row.get("motion_error")
        assert row["fit_speed_peaks"] >= 1
        assert "recorded_peaks" not in row  # a Hershey word has no time stamps
        for key in ("minjerk_duration", "minjerk_msj", "minjerk_ldj", "totg_duration",
                    "totg_msj", "totg_ldj"):
            assert math.isfinite(row[key]) and row[key] > 0, (name, key)
        assert row["totg_duration"] < 1  # time-optimal is the fastest under the same limits


def test_columns_absent_from_every_row_are_left_out() -> None:
    rows = [{"item": "a", "source": "a", "status": "ok", "moves": 3, "iou": 0.5, "other": 2.0}]
    assert bm.numeric_keys(rows) == ["moves", "iou", "other"]


def test_an_out_that_holds_files_is_refused(tmp_path: Path) -> None:
    (tmp_path / "mine.txt").write_text("keep me")
    with pytest.raises(InkmotionError, match=r"already holds results \(mine.txt\); pass "
                       "--force"):
        bm.run_benchmark(["text:hi"], tmp_path, steps=2, size=64)
    assert [p.name for p in tmp_path.iterdir()] == ["mine.txt"]


def _interruptible() -> None:
    """Give the child Ctrl-C back: a shell's background job (``cmd &``, as CI may run the
    tests) ignores SIGINT, and a Python started so never turns it into KeyboardInterrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.skipif(sys.platform == "win32", reason="process groups and SIGINT")
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_ctrl_c_leaves_nothing(tmp_path: Path, jobs: str) -> None:
    """SIGINT to the command's process group (what Ctrl-C in a terminal sends) while an
    item is being fitted: no output folder, no staging folder, not even the parents the
    run created, and the command says so."""
    out = tmp_path / "a" / "b" / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "inkmotion", "benchmark", "text:hi", "text:ok", "text:abc",
         "--jobs", jobs, "--steps", "5000", "--size", "96", "--out", str(out)],
        start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=_interruptible)
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob("a/b/out.partial-*/*.partial-*")):  # a fit has begun
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            time.sleep(0.1)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    # 130, or killed by the SIGINT itself (-2): a shell shows both as 130. Seen once in a
    # full run under load: the command had cleaned up and said so, then ended by the
    # signal; not reproduced in 39 runs of the case alone, 31 of them beside two busy cores
    assert proc.returncode in (130, -signal.SIGINT), err
    assert f"interrupted; nothing was written to {out}" in err
    assert list(tmp_path.iterdir()) == []
