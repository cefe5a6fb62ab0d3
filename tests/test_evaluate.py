"""End-to-end: ``inkmotion evaluate`` on a fitted word: the table, the files, the ratios."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest


def inkmotion(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=300, env=env)


def test_evaluate_writes_the_table_and_plots(tmp_path: Path) -> None:
    fit = tmp_path / "fit"
    res = inkmotion("run", "fit", "text:hi", "--out", str(fit), "--steps", "40", "--size",
                    "150", "--no-record")
    assert res.returncode == 0, res.stderr
    out = tmp_path / "eval"
    res = inkmotion("evaluate", str(fit / "plan.json"), "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert {"evaluation.json", "evaluation.csv", "speeds.png", "minima.png"} <= {
        p.name for p in out.iterdir()}
    doc = json.loads((out / "evaluation.json").read_text())
    methods = doc["methods"]
    assert set(methods) == {"sigma-lognormal", "minimum-jerk", "minimum-jerk-sigma-times",
                            "time-optimal"}
    assert all(m["ldj"] < 0 and m["msj"] > 0 for m in methods.values())
    assert methods["time-optimal"]["duration"] < methods["sigma-lognormal"]["duration"]
    assert doc["ratios"]["time-optimal"]["duration"] < 1
    # the ΣΛ passage times keep the ΣΛ timing law: the same duration under the same limits
    assert doc["ratios"]["minimum-jerk-sigma-times"]["duration"] == pytest.approx(1.0,
                                                                                   abs=0.02)
    assert "time-optimal/ΣΛ" in res.stderr  # the table on the terminal
    # every path, and the drawing's total: durations add up
    assert doc["path"] == "all" and len(doc["paths"]) == len(
        json.loads((fit / "plan.json").read_text())["paths"])
    if len(doc["paths"]) > 1:
        total = sum(p["methods"]["sigma-lognormal"]["duration"] for p in doc["paths"])
        assert methods["sigma-lognormal"]["duration"] == pytest.approx(total)
    csv = (out / "evaluation.csv").read_text().splitlines()
    rows = 1 + 7 * (1 + (len(doc["paths"]) if len(doc["paths"]) > 1 else 0))
    assert len(csv) == rows and "nan" not in "".join(csv)
    one = tmp_path / "one"
    res = inkmotion("evaluate", str(fit / "plan.json"), "--path", "0", "--out", str(one))
    assert res.returncode == 0, res.stderr
    assert json.loads((one / "evaluation.json").read_text())["path"] == 0
    # a --recording without time stamps has no speeds to compare: said, not silent
    res = inkmotion("evaluate", str(fit / "plan.json"), "--recording", "text:hi", "--out",
                    str(tmp_path / "untimed"), "--no-record")
    assert res.returncode == 0, res.stderr
    assert "warning: text:hi: the points carry no time stamps" in res.stderr
    # a timed recording of another drawing: its speed agreement is computed but said to
    # say little, for its strokes lie far from the plan's motion
    res = inkmotion("evaluate", str(fit / "plan.json"), "--recording", "sample:tempt-1",
                    "--out", str(tmp_path / "other"), "--no-record")
    assert res.returncode == 0, res.stderr
    assert "warning: sample:tempt-1: its strokes lie" in res.stderr
    assert "it does not look like the drawing the plan was fitted to" in res.stderr
    human = json.loads((tmp_path / "other" / "evaluation.json").read_text())["human"]
    assert human["apart_px"] > 15 and human["has_times"]
    assert human["time_unit"] == "ms"  # told by the step
    # the unit given, as the README says (it had no such option: "no such option")
    res = inkmotion("evaluate", str(fit / "plan.json"), "--recording", "sample:tempt-1",
                    "--recording-time-unit", "s", "--out", str(tmp_path / "in-s"),
                    "--no-record")
    assert res.returncode == 0, res.stderr
    human = json.loads((tmp_path / "in-s" / "evaluation.json").read_text())["human"]
    assert human["time_unit"] == "s"


def test_msj_at_equal_duration_removes_the_time_scaling() -> None:
    """The same path timed k× slower: MSJ falls by k⁶, LDJ is unchanged, and the ratio of
    MSJ·T⁶ is 1 (up to the sampling)."""
    import numpy as np

    from inkmotion.evaluation import metrics as M
    from inkmotion.evaluation.comparison import ratio_row

    def figures(duration: float) -> dict[str, float]:
        tau = np.linspace(0.0, 1.0, 2001)
        s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
        xy = np.column_stack([np.cos(2 * s), np.sin(3 * s)])
        return M.trajectory_metrics(xy, duration / 2000)

    slow, fast = figures(2.0), figures(1.0)
    r = ratio_row(fast, slow)
    assert r["duration"] == 0.5
    assert r["msj"] == pytest.approx(64.0, rel=1e-6)
    assert r["ldj"] == pytest.approx(1.0, rel=1e-9)
    assert r["msj_equal_duration"] == pytest.approx(1.0, rel=1e-6)


def test_a_fit_says_what_its_speed_comparison_left_out_and_the_time_unit(tmp_path: Path
                                                                          ) -> None:
    """run fit left a stroke whose clock jumped back 400 ms in its speed comparison (a false
    plateau) and read a 68-ms dash's milliseconds as seconds (544 s), without a word;
    evaluate --recording says the same as the fit."""
    import math

    def stroke(y: float, stamps: list[float]) -> str:
        return "<stroke>" + "".join(
            f"<pt><x>{0.1 + 0.8 * i / 59:.4f}</x><y>{y + 0.05 * math.sin(i / 6):.4f}</y>"
            f"<t>{t}</t></pt>" for i, t in enumerate(stamps)) + "</stroke>"

    steady = [2.0 * i for i in range(60)]
    jumped = [200.0 + 2.0 * i - (400.0 if i >= 30 else 0.0) for i in range(60)]
    gml = tmp_path / "jump.gml"
    gml.write_text(f"<gml><tag><drawing>{stroke(0.3, steady)}{stroke(0.7, jumped)}"
                   "</drawing></tag></gml>")
    fit = tmp_path / "fit"
    res = inkmotion("run", "fit", str(gml), "--out", str(fit), "--steps", "30", "--size",
                    "160", "--no-record")
    assert res.returncode == 0, res.stderr
    said = "the clock runs backwards inside 1 of its 2 strokes (stroke 2; by up to 398 ms)"
    assert said in res.stderr
    recorded = json.loads((fit / "report.json").read_text())["recorded"]
    assert recorded["time_unit"] == "ms"
    assert recorded["recorded_duration_s"] == pytest.approx(0.118, abs=0.005)  # not 118 s
    res = inkmotion("evaluate", str(fit / "plan.json"), "--recording", str(gml), "--out",
                    str(tmp_path / "eval"))
    assert res.returncode == 0, res.stderr
    assert said in res.stderr
    # a drawing with no time stamps at all (an SVG, a picture) is not warned about them
    svg = tmp_path / "line.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 50"><path '
                   'd="M5 25 C 30 0, 70 50, 95 25" stroke="black" fill="none"/></svg>')
    res = inkmotion("run", "fit", str(svg), "--out", str(tmp_path / "svg"), "--steps", "20",
                    "--size", "160", "--no-record")
    assert res.returncode == 0, res.stderr
    assert "warning" not in res.stderr, res.stderr


def test_every_method_s_jerk_is_taken_from_its_exact_acceleration() -> None:
    """The ΣΛ positions carry the lognormals' tails beyond ±5σ (3·10⁻⁷ of a stroke), which
    join where each window ends: differentiated three times, those steps made the ΣΛ MSJ
    13–28 % high on real fits. Its MSJ is the mean of its own jerk (the exact acceleration's
    central difference) to within the sampling."""
    import numpy as np

    from inkmotion.evaluation.comparison import compare
    from inkmotion.sigma_lognormal.plan import MotorPlan

    plan = MotorPlan.from_points([[0, 0], [180, 40], [60, 220], [300, 260], [120, 40],
                                  [330, 10]])
    plan.delta_t.fill_(0.35)
    plan.delta.copy_(plan.delta.new_tensor([0.9, -0.6, 1.2, -1.0, 0.4]))
    result = compare(plan, 0.25, 2.5, scale=7.6e-4)  # a 350-px canvas on A4
    sigma = result.timed["sigma-lognormal"]
    jerk = sigma.jerk * 7.6e-4
    own = float(np.trapezoid((jerk * jerk).sum(axis=1), sigma.t)) / float(sigma.t[-1])
    assert result.table["sigma-lognormal"]["msj"] == pytest.approx(own, rel=0.01)
