"""Fit quality on hard inputs at the default settings (issue 19): the fit's own figures
against the goals, not timings. Sharp polygons (the corners that a plan's overlaps cut and
a merge used to remove), and, where ../shared is present, the corpus tags whose fit used to
take another route. A poor fit says so; an option that cannot take effect says why."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "gml"
#: (a P with a closed, sharp-cornered bowl; a zigzag of 60° turns; a square spiral)
POLYGONS = {
    "p": "29,149 29,46 109,46 109,95 68,104 28,93",
    "zigzag": "10,100 40,40 70,100 100,40 130,100 160,40",
    "spiral": "80,80 120,80 120,120 40,120 40,40 160,40 160,160",
}
#: corpus tags whose default fit missed by 30–78 px before issue 19
HARD_TAGS = ("corpus/temptTag-2010_7_29_14_0_28.gml", "corpus/temptTag-2010_7_28_15_31_29.gml")


def inkmotion(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore", "INKMOTION_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=600, env=env)


def _svg(tmp_path: Path, name: str, points: str) -> Path:
    path = tmp_path / f"{name}.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 170 170">'
                    f'<polyline points="{points}" fill="none" stroke="black"/></svg>')
    return path


def _fit(source: Path | str, out: Path, *extra: str) -> tuple[dict, subprocess.CompletedProcess]:
    res = inkmotion("run", "fit", str(source), "--out", str(out), "--no-record", "--seed", "1",
                    *extra)
    assert res.returncode == 0, res.stderr
    return json.loads((out / "report.json").read_text()), res


def _meets_the_goals(report: dict) -> None:
    assert report["chamfer_mean_px"] <= 0.6, report["chamfer_mean_px"]
    assert report["chamfer_max_px"] <= 8.0, report["chamfer_max_px"]
    assert report["delta_t_at_clamp"] == 0 and report["pinned_overlaps"] == []
    assert report["quality"] == "good"
    # no warning about the fit (one about the recording's time stamps may be there: the
    # EyeWriter tags hold too few for speed peaks)
    assert [w for w in report.get("warnings", []) if "time stamps" not in w] == []
    for stage in report["stages"]:  # every edit says whether it was kept and why
        if "edit" in stage:
            assert isinstance(stage["edit"]["kept"], bool) and stage["edit"]["why"]


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(POLYGONS))
def test_sharp_polygons_keep_their_corners(tmp_path: Path, name: str) -> None:
    report, _ = _fit(_svg(tmp_path, name, POLYGONS[name]), tmp_path / "out")
    _meets_the_goals(report)
    corners = len(POLYGONS[name].split()) - 1
    assert report["moves"] >= corners  # every corner keeps a sub-movement of its own
    assert report["t_end_ratio_multi"] < 1.0


@pytest.mark.slow
@pytest.mark.parametrize("tag", HARD_TAGS)
def test_hard_corpus_tags(tmp_path: Path, tag: str) -> None:
    if not (SHARED / tag).is_file():
        pytest.skip("../shared/data/gml is not here")
    report, _ = _fit(SHARED / tag, tmp_path / "out")
    _meets_the_goals(report)
    assert report["t_end_ratio_multi"] <= 0.65


@pytest.mark.slow
def test_the_tall_loops_of_a_script_word_are_drawn(tmp_path: Path) -> None:
    """giraffe's two f loops are each a few sub-movements that turn most of a half circle:
    started at a quarter circle with δ learning at 0.1 (spec 16) the fit cut them across,
    0.96 px mean; each δ starting at its bend and learning at 0.2 draws them (0.41 px)
    within the authors' density (26 targets, 1.25× at most). At spec 18 the first edit's
    refit ended at 0.602 px, 0.002 short of the mean goal, and was rolled back (0.643 px);
    spec 19 keeps an edit that halves a goal's miss, and the fit goes on to 0.42 px."""
    report, _ = _fit("text:giraffe", tmp_path / "out")
    _meets_the_goals(report)
    assert report["moves"] <= 32
    assert report["t_end_ratio_multi"] <= 0.65


def test_a_poor_fit_warns_where_and_what_to_try(tmp_path: Path) -> None:
    """One sub-movement per stroke cannot draw a P: the fit ends, says so in one warning
    naming the stroke and the distance, and report.json says "poor"."""
    report, res = _fit(_svg(tmp_path, "p", POLYGONS["p"]), tmp_path / "out", "--targets",
                       "1", "--steps", "60")
    assert report["quality"] == "poor"
    assert report["quality_figures"]["worst_distance_px"] > 8.0
    warnings = [line for line in res.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1
    assert "misses stroke 1 of 1 by" in warnings[0] and "--steps" in warnings[0]
    assert "--dce-bend-estimate between" in warnings[0]  # the initialiser's other start
    assert "quality POOR" in res.stdout


def test_targets_that_cannot_be_met_say_why(tmp_path: Path) -> None:
    data = Path(__file__).parent / "data" / "tag.gml"
    report, res = _fit(data, tmp_path / "out", "--targets", "30", "--steps", "30",
                       "--max-error", "1.5", "--no-merge")
    assert report["moves"] < 30
    assert any(w.startswith("--targets 30: the dce initialiser made") for w in
               report["warnings"])
    assert "input vertices only" in res.stderr
    # options of the other modes say that they do nothing here
    assert "warning: --max-error applies to --targets auto only" in res.stderr
    assert "warning: --no-merge applies to --targets default only" in res.stderr


def test_the_gallery_card_of_a_poor_fit_says_so(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    report, _ = _fit(_svg(tmp_path, "p", POLYGONS["p"]), runs / "poor", "--targets", "1",
                     "--steps", "20")
    assert report["quality"] == "poor"
    site = tmp_path / "site"
    res = inkmotion("gallery", "build", "--no-store", "--from", str(runs), "--out", str(site))
    assert res.returncode == 0, res.stderr
    index = (site / "index.html").read_text()
    assert 'class="poor"' in index and "poor fit" in index
    page = next(site.glob("jobs/*/index.html")).read_text()
    assert "misses stroke 1 of 1" in page  # the warning itself on the job's page


def test_overlaps_left_on_their_bound_are_named_with_what_to_try(tmp_path: Path) -> None:
    """Four targets along one straight line: nothing holds the sub-movements apart, the
    minimum-time cost pins every overlap on its 0.1 floor (without spec 15's floor
    barrier, which holds them just off it). The fit says where, what it means and what to
    try, and report.json lists them; one target draws the line with none."""
    line = _svg(tmp_path, "line", "10,100 60,100 110,100 160,100")
    report, res = _fit(line, tmp_path / "four", "--initialiser", "line", "--targets", "4",
                       "--steps", "150", "--w-floor", "0")
    assert report["delta_t_at_clamp"] == 1.0 and report["quality"] == "good"
    assert report["pinned_overlaps"] == [{"path": 1, "move": i, "bound": 0.1}
                                         for i in (2, 3, 4)]
    warnings = [line for line in res.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1
    assert "3 of 3 overlaps sits on its bound (path 1: sub-movements 2, 3, 4)" in warnings[0]
    assert "--targets 1." in warnings[0] and "--refine 0" not in warnings[0]
    report, res = _fit(line, tmp_path / "one", "--targets", "1", "--steps", "150")
    assert report["pinned_overlaps"] == [] and "warning:" not in res.stderr


def test_a_drawing_too_small_for_its_pen_says_which_size_gives_it_room(tmp_path: Path) -> None:
    """A long line of text at 350 px is a few px tall under a 3-px pen: the fit follows it
    (rated good) but its letters merge. It says so and names a --size; a thin drawing whose
    strokes stay apart (a dashed line) says nothing."""
    line = "text:" + " ".join(["the quick brown fox jumps over the lazy dog"] * 3)
    report, res = _fit(line, tmp_path / "line", "--steps", "20")
    (said,) = [w for w in report["warnings"] if "shorter side" in w]
    assert "strokes merge and it is hard to read" in said and "give --size 2000" in said
    dashes = tmp_path / "dashes.svg"
    dashes.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 300 10"><path '
                      'd="M0 5 L40 5 M60 5 L100 5 M120 5 L160 6" stroke="black"/></svg>')
    report, _ = _fit(dashes, tmp_path / "dashes", "--steps", "20")
    assert not any("shorter side" in w for w in report.get("warnings", []))
    stray = tmp_path / "stray.gml"  # one glitched point 10^308 away: no canvas gives it room
    stray.write_text("<gml><tag><drawing><stroke><pt><x>0.1</x><y>0.1</y></pt><pt><x>1e308</x>"
                     "<y>0.5</y></pt><pt><x>0.3</x><y>0.9</y></pt></stroke></drawing></tag></gml>")
    report, _ = _fit(stray, tmp_path / "stray", "--steps", "5")
    (said,) = [w for w in report["warnings"] if "shorter side" in w]
    assert "look for a stray point far from the rest" in said and "--size" not in said


def _deltas(folder: Path) -> list[float]:
    plan = json.loads((folder / "plan.json").read_text())
    return [d for path in plan["paths"] for d in path["delta"]]


def test_the_report_says_how_many_turns_sit_on_their_clamp(tmp_path: Path) -> None:
    """δ clamped at ±--max-turn (the most one arc may turn) is where the model's curvature
    limit binds: report.json gives its share, as it does the overlaps' on a bound. At the
    authors' quarter circle (90°) tempt-3's hooks sit on it; the default half circle lets
    them turn further, and fewer sit on their clamp."""
    import math

    quarter, _ = _fit("sample:tempt-3", tmp_path / "t3", "--steps", "60", "--max-turn", "90")
    deltas = _deltas(tmp_path / "t3")
    at = sum(abs(abs(d) - math.pi / 2) <= 1e-6 for d in deltas)
    assert max(abs(d) for d in deltas) <= math.pi / 2 + 1e-6
    assert quarter["delta_at_clamp"] == pytest.approx(at / len(deltas))
    assert quarter["metrics"]["delta_at_clamp"] == quarter["delta_at_clamp"]
    assert at > 0  # tempt-3's hooks turn as far as an arc may
    half, _ = _fit("sample:tempt-3", tmp_path / "t3h", "--steps", "60")
    deltas = _deltas(tmp_path / "t3h")
    assert max(abs(d) for d in deltas) > math.pi / 2  # a hook turns past a quarter circle
    at_half = sum(abs(abs(d) - math.pi) <= 1e-6 for d in deltas)
    assert half["delta_at_clamp"] == pytest.approx(at_half / len(deltas))
    assert half["delta_at_clamp"] < quarter["delta_at_clamp"]


def _plan_field(folder: Path, name: str) -> list[list[float]]:
    plan = json.loads((folder / "plan.json").read_text())
    return [path[name] for path in plan["paths"]]


def test_learned_shapes_keep_the_overlaps_off_their_floor(tmp_path: Path) -> None:
    """Spec 15 fits each lognormal's shape Ac too: a skewed sub-movement does most of its
    movement early in its window, so the next window may open sooner. tempt-2's two hooks
    (two moves each) then slid their overlaps onto the 0.1 floor under the time cost; the
    floor barrier keeps them off it, at the same accuracy."""
    bare, _ = _fit("sample:tempt-2", tmp_path / "bare", "--w-floor", "0")
    assert bare["pinned_overlaps"] and bare["delta_t_at_clamp"] > 0  # what the barrier is for
    report, _ = _fit("sample:tempt-2", tmp_path / "t2")
    _meets_the_goals(report)
    overlaps = [d for path in _plan_field(tmp_path / "t2", "delta_t") for d in path[1:]]
    assert overlaps and min(overlaps) >= 0.1 + 0.01
    shapes = [a for path in _plan_field(tmp_path / "t2", "ac") for a in path]
    assert len({round(a, 4) for a in shapes}) > 2  # the shapes learned, each its own
    at = sum(min(abs(a - 1e-4), abs(a - 0.1)) <= 1e-6 for a in shapes)
    assert report["ac_at_clamp"] == pytest.approx(at / len(shapes))
    assert report["metrics"]["ac_at_clamp"] == report["ac_at_clamp"]
    assert report["shapes_learned"] is True
    assert bare["ac_at_clamp"] >= 0 and at > 0  # tempt-2's hooks want more skew than 0.1
    assert report["chamfer_mean_px"] <= bare["chamfer_mean_px"] + 0.05
