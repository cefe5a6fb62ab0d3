"""Evaluation metrics on analytic cases (minimum jerk, circles, ellipses) and the agreement
with recorded human motion (a synthetic recording, then the real tags when present)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from inkmotion.evaluation import human as H
from inkmotion.evaluation import metrics as M

GML = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "gml"
#: the closed form of LDJ for a minimum-jerk point-to-point movement: −ln(720·64/225)
MIN_JERK_LDJ = -math.log(720.0 * 64.0 / 225.0)


def min_jerk(amplitude: float = 1.0, duration: float = 1.0, n: int = 1001,
             direction: tuple[float, float] = (0.6, 0.8)) -> tuple[np.ndarray, float]:
    """x(τ) = A(10τ³ − 15τ⁴ + 6τ⁵) along ``direction``, n samples over [0, T]."""
    tau = np.linspace(0.0, 1.0, n)
    s = amplitude * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
    return s[:, None] * np.asarray(direction)[None, :], duration / (n - 1)


def test_min_jerk_ldj_matches_the_closed_form():
    assert MIN_JERK_LDJ == pytest.approx(-5.3220, abs=1e-4)
    position, dt = min_jerk()
    assert M.ldj(position, dt) == pytest.approx(MIN_JERK_LDJ, abs=1e-3)
    # 3-D positions: the radius column is ignored
    with_radius = np.column_stack([position, np.full(len(position), 7.0)])
    assert M.ldj(with_radius, dt) == pytest.approx(M.ldj(position, dt), abs=1e-12)


def test_ldj_with_exact_derivatives():
    n, T, A = 501, 0.8, 2.0
    tau = np.linspace(0.0, 1.0, n)
    d = np.array([1.0, 0.0])
    position = (A * (10 * tau**3 - 15 * tau**4 + 6 * tau**5))[:, None] * d
    velocity = (A / T * (30 * tau**2 - 60 * tau**3 + 30 * tau**4))[:, None] * d
    acceleration = (A / T**2 * (60 * tau - 180 * tau**2 + 120 * tau**3))[:, None] * d
    dt = T / (n - 1)
    got = M.ldj(position, dt, velocity=velocity, acceleration=acceleration)
    assert got == pytest.approx(MIN_JERK_LDJ, abs=1e-4)
    assert M.msj(position, dt, acceleration=acceleration) == pytest.approx(
        720 * A**2 / T**6, rel=1e-4)
    jerk = M.jerk_from(acceleration, dt)
    exact = A / T**3 * (60 - 360 * tau + 360 * tau**2)
    assert np.max(np.abs(jerk[:, 0] - exact)) < 1e-3 * np.max(np.abs(exact))


def test_ldj_is_invariant_to_space_and_time_scaling():
    base = M.ldj(*min_jerk(1.0, 1.0))
    assert M.ldj(*min_jerk(3.0, 2.0)) == pytest.approx(base, abs=1e-9)
    assert M.ldj(*min_jerk(0.01, 0.25)) == pytest.approx(base, abs=1e-9)


def test_msj_follows_its_definition_and_scales_as_a2_over_t6():
    position, dt = min_jerk(1.0, 1.0)
    assert M.msj(position, dt) == pytest.approx(720.0, rel=1e-4)  # (1/T)·720A²/T⁵
    for A, T in ((3.0, 2.0), (0.5, 0.3)):
        ratio = M.msj(*min_jerk(A, T)) / M.msj(position, dt)
        assert ratio == pytest.approx(A**2 / T**6, rel=1e-9)


def test_speed_peaks_and_minima():
    position, dt = min_jerk(1.0, 1.0)
    s = M.speed(position, dt)
    assert s.max() == pytest.approx(15.0 / 8.0, rel=1e-5)
    assert M.peak_speed(position, dt) == pytest.approx(15.0 / 8.0, rel=1e-5)
    assert list(M.speed_peaks(s, dt)) == [500]
    assert len(M.speed_minima(s, dt)) == 0
    # two movements one after the other, the second at right angles
    second, _ = min_jerk(0.5, 1.0, direction=(-0.8, 0.6))
    both = np.vstack([position, position[-1] + second[1:]])
    s2 = M.speed(both, dt)
    assert len(M.speed_peaks(s2, dt)) == 2
    assert list(M.speed_minima(s2, dt)) == [1000]
    # noise: smoothing keeps the count
    rng = np.random.default_rng(0)
    noisy = s2 + rng.normal(0.0, 0.02, len(s2))
    assert len(M.speed_peaks(noisy, dt, smooth_s=0.03)) == 2


def test_duration_and_uniform_step():
    t = np.linspace(0.5, 2.5, 201)
    assert M.duration(t) == pytest.approx(2.0)
    assert M.uniform_step(t) == pytest.approx(0.01)
    with pytest.raises(ValueError):
        M.uniform_step(np.array([0.0, 0.1, 0.3]))


@pytest.mark.parametrize("radius", [1.0, 40.0])
def test_curvature_of_a_circle_is_one_over_r(radius):
    t = np.linspace(0.0, 2.0, 2001)
    theta = 2 * np.pi * (t + 0.2 * t**2)  # non-uniform angular speed
    position = radius * np.column_stack([np.cos(theta), np.sin(theta)])
    kappa = M.curvature(position, t[1] - t[0])
    assert np.allclose(kappa[2:-2], 1.0 / radius, rtol=1e-4)


def test_speed_minima_sit_at_curvature_maxima_on_an_ellipse():
    # harmonic motion on an ellipse obeys the 2/3 power law: slowest where most curved
    t = np.linspace(0.0, 2.0, 4001)
    position = np.column_stack([2.0 * np.cos(2 * np.pi * t), np.sin(2 * np.pi * t)])
    got = M.speed_minima_at_curvature_maxima(position, t[1] - t[0])
    assert got["curvature_maxima"] == 3 and got["speed_minima"] == 3  # θ = π, 2π, 3π
    assert got["curvature_maxima_with_speed_minimum"] == 1.0
    assert got["speed_minima_with_curvature_maximum"] == 1.0
    assert abs(got["median_lag_s"]) < 1e-9
    # a straight line has neither
    line, dt = min_jerk()
    none = M.speed_minima_at_curvature_maxima(line, dt)
    assert none["curvature_maxima_with_speed_minimum"] is None


def test_trajectory_metrics_bundle():
    position, dt = min_jerk(2.0, 1.0)
    got = M.trajectory_metrics(position, dt)
    assert set(got) == {"duration", "peak_speed", "speed_peaks", "msj", "ldj"}
    assert got["duration"] == pytest.approx(1.0)
    assert got["speed_peaks"] == 1
    assert got["ldj"] == pytest.approx(MIN_JERK_LDJ, abs=1e-3)
    assert got["msj"] == pytest.approx(720 * 4.0, rel=1e-4)


# ---------------------------------------------------------------- human recordings


def two_bell_motion(t: np.ndarray) -> np.ndarray:
    """A curved stroke over t ∈ [0, 1] s whose speed has two bells (arc length is two
    minimum-jerk segments of 60 and 40 px) along a quarter circle of radius 100 px."""
    tau = np.clip(np.where(t < 0.5, t / 0.5, (t - 0.5) / 0.5), 0.0, 1.0)
    mj = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    s = np.where(t < 0.5, 60.0 * mj, 60.0 + 40.0 * mj)
    phi = s / 100.0
    return np.column_stack([100.0 * np.cos(phi), 100.0 * np.sin(phi)])


def synthetic_recording(seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Points of :func:`two_bell_motion` at irregular times, stamped in ms."""
    rng = np.random.default_rng(seed)
    t = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, 150)]))
    return two_bell_motion(t), 1000.0 * t + 250.0


def test_times_in_seconds_detects_milliseconds():
    """The step between stamps tells the unit where a stroke's duration cannot: a 68-ms
    dash sampled at 500 Hz in ms, a two-minute spiral at 10 Hz in s."""
    ms, unit = H.times_in_seconds([np.arange(0.0, 50.0, 5.0), np.arange(300.0, 455.0, 5.0)])
    assert unit == "ms" and ms[1][-1] == pytest.approx(0.45)
    dashes, unit = H.times_in_seconds([np.arange(0.0, 70.0, 2.0) + 100.0 * k for k in range(8)])
    assert unit == "ms" and dashes[0][-1] == pytest.approx(0.068)
    spiral, unit = H.times_in_seconds([np.arange(0.0, 120.6, 0.1)])
    assert unit == "s" and spiral[0][-1] == pytest.approx(120.5)
    s, unit = H.times_in_seconds([np.linspace(0.1, 1.2, 200)])
    assert unit == "s" and s[0][-1] == pytest.approx(1.2)
    declared, unit = H.times_in_seconds([np.arange(0.0, 120.6, 0.1)], "ms")
    assert unit == "ms" and declared[0][-1] == pytest.approx(0.1205)


def test_time_anchors_take_the_last_point_of_each_stamp():
    arc = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0])
    t = np.array([0.0, 0.0, 0.1, 0.1, 0.05, 0.2])  # a repeated and a backwards stamp
    at, s = H.time_anchors(arc, t)
    assert list(at) == [0.0, 0.1, 0.2]
    assert list(s) == [0.0, 4.0, 5.0]


def test_recorded_speed_of_a_synthetic_recording():
    points, t_ms = synthetic_recording()
    arc, speed, times = H.recorded_speed(points, t_ms, rate=200, smooth_s=0.01)
    assert times[0] == pytest.approx(0.25) and times[-1] == pytest.approx(1.25, abs=0.005)
    assert np.all(np.diff(arc) >= 0) and arc[-1] == pytest.approx(100.0, rel=1e-3)
    assert len(M.speed_peaks(speed, 1 / 200)) == 2
    assert speed.max() == pytest.approx(60.0 * 15 / 8 / 0.5, rel=0.05)  # 225 px/s


def test_a_recording_agrees_with_itself():
    points, t_ms = synthetic_recording()
    truth = two_bell_motion(np.linspace(0.0, 1.0, 401))
    truth_speed = M.speed(truth, 1.0 / 400)
    arc, speed, _ = H.recorded_speed(points, t_ms)
    got = H.compare_peaks(arc, speed, H.arc_length(truth), truth_speed, tolerance=0.05)
    assert got["recorded_peaks"] == got["fit_peaks"] == got["matched"] == 2
    assert got["mean_offset"] < 0.01
    assert got["fit_at"] == pytest.approx([0.3, 0.8], abs=0.01)  # halfway along each bell
    result = H.human_agreement([(points, t_ms / 1000.0)] * 2, [(truth, truth_speed)] * 2)
    total = result["total"]
    assert total["recorded_peaks"] == total["fit_peaks"] == total["matched_peaks"] == 4
    assert total["recorded_duration_s"] == pytest.approx(2.0, abs=0.02)
    assert total["mean_position_offset"] < 0.01


def test_compare_peaks_counts_unmatched_peaks():
    arc = np.linspace(0.0, 1.0, 101)
    one = np.exp(-((arc - 0.5) / 0.1) ** 2)
    two = np.exp(-((arc - 0.2) / 0.05) ** 2) + np.exp(-((arc - 0.8) / 0.05) ** 2)
    got = H.compare_peaks(arc, one, arc, two, tolerance=0.1)
    assert (got["recorded_peaks"], got["fit_peaks"], got["matched"]) == (1, 2, 0)
    assert got["mean_offset"] is None


def test_plot_speed_profiles_writes_a_png(tmp_path):
    points, t_ms = synthetic_recording()
    arc, speed, _ = H.recorded_speed(points, t_ms)
    out = tmp_path / "speeds.png"
    H.plot_speed_profiles(out, [(arc, speed), (arc, speed)], [(arc, speed), (arc, speed)])
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _gml(path: Path, strokes: list[list[tuple[float, float, float]]]) -> str:
    """A GML file of ``strokes`` of (x, y, t) points."""
    body = "".join("<stroke>" + "".join(f"<pt><x>{x}</x><y>{y}</y><t>{t}</t></pt>"
                                        for x, y, t in st) + "</stroke>" for st in strokes)
    path.write_text(f'<gml spec="1.0"><tag><drawing>{body}</drawing></tag></gml>')
    return str(path)


def _agreement_of(tmp_path: Path, name: str,
                  strokes: list[list[tuple[float, float, float]]]) -> dict:
    """The recorded speed agreement of a GML of ``strokes`` of (x, y, t) points with a DCE
    plan of the same strokes (:func:`H.human_agreement_of_traces`)."""
    import torch

    from inkmotion.initialisers.dce import dce
    from inkmotion.kinds.read import read_input
    from inkmotion.sigma_lognormal.plan import Drawing, MotorPlan

    source = _gml(tmp_path / name, strokes)
    traces = read_input(source).fit_to_canvas(350)
    plans = [MotorPlan.from_points(dce(s), dtype=torch.float64) for s in traces.strokes]
    drawing = Drawing((traces.width, traces.height), plans)
    return H.human_agreement_of_traces(read_input(source), drawing, tmp_path / f"{name}.png",
                                       source)


def _timed(lines: tuple, stamps: list[list[float]]) -> list[list[tuple[float, float, float]]]:
    """(x, y, t) strokes of the polylines ``lines`` with the times ``stamps``."""
    return [[(x, y, t) for (x, y), t in zip(st, ts, strict=True)]
            for st, ts in zip(lines, stamps, strict=True)]


def test_time_stamps_that_do_not_advance_give_no_recorded_speed(tmp_path):
    """Some exporters stamp every point 0, or their clocks run backwards: such a stroke
    has no recorded speed, so it is left out of the comparison (and a recording with no
    other is said to have none), not a ValueError at the end of a fit."""
    wave = [(0.1 + 0.01 * i, 0.5 + 0.1 * math.sin(i / 5)) for i in range(60)]
    low = [(x, y + 0.3) for x, y in wave]

    def agreement(name: str, stamps: list[list[float]]) -> dict:
        return _agreement_of(tmp_path, name, _timed((wave, low), stamps))

    assert not H.advances(np.zeros(5)) and not H.advances(np.linspace(1, 0, 5))
    assert H.advances(np.array([0.0, 0.0, 0.1]))
    zero = agreement("zero.gml", [[0.0] * 60, [0.0] * 60])
    assert not zero["has_times"] and "do not advance" in zero["note"]
    backwards = agreement("back.gml", [list(np.linspace(1, 0, 60))] * 2)
    assert not backwards["has_times"]
    one = agreement("one.gml", [[0.0] * 60, list(np.linspace(1.2, 2.4, 60))])
    assert one["has_times"] and one["strokes_paired"] == 1 and one["strokes_untimed"] == 1
    assert "1 of its 2 strokes have time stamps that do not advance" in one["note"]
    assert "note" not in agreement("both.gml", [list(np.linspace(0, 1, 60))] * 2)


@pytest.mark.skipif(not GML.is_dir(), reason="the shared tag folder is absent")
def test_real_tags_carry_times_and_agree_with_a_plan(tmp_path):
    import torch

    from inkmotion.errors import InputError
    from inkmotion.initialisers.dce import dce
    from inkmotion.kinds.read import read_input
    from inkmotion.sigma_lognormal.plan import Drawing, MotorPlan

    timed = {}
    for path in sorted(GML.iterdir()):
        try:
            traces = read_input(str(path))
        except InputError:
            continue
        if traces.meta.get("t") is not None:
            seconds, unit = H.times_in_seconds(traces.meta["t"])
            timed[path.name] = (unit, sum(float(t[-1] - t[0]) for t in seconds))
    print({name: (unit, round(d, 3)) for name, (unit, d) in timed.items()})
    assert {"49867.json", "49873.json"} <= set(timed)

    source = str(GML / "49867.json")
    traces = read_input(source).fit_to_canvas(350)
    assert [len(t) for t in traces.meta["t"]] == [len(s) for s in traces.strokes]
    plans = [MotorPlan.from_points(dce(s), dtype=torch.float64) for s in traces.strokes]
    drawing = Drawing((traces.width, traces.height), plans)
    got = H.human_agreement_of_traces(read_input(source), drawing, tmp_path / "human.png",
                                      source)
    print(got["total"])
    assert got["has_times"] and got["time_unit"] == "s"
    assert got["strokes_paired"] == len(traces.strokes)
    assert got["total"]["recorded_peaks"] > 0 and got["total"]["fit_peaks"] > 0
    assert (tmp_path / "human.png").stat().st_size > 1000


@pytest.mark.skipif(not GML.is_dir(), reason="the shared tag folder is absent")
def test_item_figures_of_a_timed_tag(tmp_path):
    """The benchmark's motion figures of a plan of 49867.json: the fit's peaks, the
    recording's, the pairing and its plot, and the evaluation ratios."""
    import torch

    from inkmotion.evaluation.fit_motion import item_figures
    from inkmotion.initialisers.dce import dce
    from inkmotion.kinds.evaluate import recorded_agreement
    from inkmotion.kinds.read import read_input
    from inkmotion.sigma_lognormal.plan import Drawing, MotorPlan

    source = str(GML / "49873.json")
    traces = read_input(source).fit_to_canvas(350)
    plans = [MotorPlan.from_points(dce(s, threshold=20.0), dtype=torch.float64)
             for s in traces.strokes]
    Drawing((traces.width, traces.height), plans).save(tmp_path / "plan.json")
    human, note = recorded_agreement(source, Drawing.load(tmp_path / "plan.json"),
                                     tmp_path / "human_speeds.png")
    assert human["time_unit"] == "s"
    assert "a median of 7 time stamps each, too few" in note  # the paper's 49873 is sparse
    got = item_figures(tmp_path, human)
    print(got)
    assert got["fit_speed_peaks"] >= len(plans)
    assert got["recorded_peaks"] > len(plans)
    assert 0 < got["matched_peaks"] <= min(got["recorded_peaks"], got["fit_speed_peaks"])
    assert 0.0 <= got["peak_offset"] <= 0.1
    assert got["recorded_duration_s"] > 1.0
    assert (tmp_path / "human_speeds.png").stat().st_size > 1000
    assert got["totg_duration"] < 1.0 and got["minjerk_duration"] > 0
    assert all(math.isfinite(got[k]) for k in ("minjerk_msj", "minjerk_ldj", "totg_msj",
                                                "totg_ldj"))
    assert recorded_agreement("text:hi", Drawing.load(tmp_path / "plan.json"),
                              tmp_path / "unused.png") == (None, None)
    words = item_figures(tmp_path, None, ratios=False)
    assert set(words) == {"fit_speed_peaks"}


def test_a_clock_that_runs_back_inside_a_stroke_leaves_it_out_and_says_so(tmp_path):
    """A clock that jumped back 400 ms mid-stroke drew a false plateau of full speed in
    human_speeds.png and counted it as a recorded peak, silently; quantised stamps and
    jitter of a few ms are no jump."""
    wave = [(0.1 + 0.01 * i, 0.5 + 0.1 * math.sin(i / 5)) for i in range(60)]
    low = [(x, y + 0.3) for x, y in wave]
    steady = [5.0 * i for i in range(60)]
    jumped = [5.0 * i - (400.0 if i >= 30 else 0.0) for i in range(60)]
    jitter = [5.0 * i + (2.0 if i % 2 else -2.0) for i in range(60)]

    def agreement(name: str, stamps: list[list[float]]) -> dict:
        return _agreement_of(tmp_path, name, _timed((wave, low), stamps))

    got = agreement("jump.gml", [steady, jumped])
    assert got["time_unit"] == "ms" and got["strokes_paired"] == 1
    assert got["strokes_clock_back"] == 1
    assert "clock runs backwards inside 1 of its 2 strokes (stroke 2; by up to 395 ms)" \
        in got["note"]
    calm = agreement("jitter.gml", [steady, jitter])
    assert calm["strokes_paired"] == 2 and "note" not in calm


def test_matched_peaks_are_set_against_chance_and_extra_fit_peaks_lower_the_f1():
    """matched_peaks counted only recorded peaks: a fit with three times the hand's peaks
    matched them all. The chance level (as many fit peaks at random) and the F1 say so."""
    arc = np.linspace(0.0, 1.0, 201)
    rec = np.exp(-((arc - 0.3) / 0.05) ** 2) + np.exp(-((arc - 0.7) / 0.05) ** 2)
    wiggly = 1.0 + 0.5 * np.cos(2 * np.pi * 6 * arc)  # a peak every 1/6
    got = H.compare_peaks(arc, rec, arc, wiggly, tolerance=0.1)
    assert got["matched"] == 2 and got["fit_peaks"] >= 6
    assert 1.0 < got["by_chance"] <= 2.0
    assert got["by_chance"] == H.compare_peaks(arc, rec, arc, wiggly, tolerance=0.1)["by_chance"]
    t = np.linspace(0.0, 1.0, 201)
    total = H.human_agreement([(np.stack([arc, 0 * arc], 1), t)],
                              [(np.stack([arc, 0 * arc], 1), wiggly)])["total"]
    assert total["peaks_f1"] == pytest.approx(2 * total["matched_peaks"]
                                              / (total["recorded_peaks"] + total["fit_peaks"]))


def test_a_recording_too_sparse_for_speed_peaks_says_so(tmp_path):
    """The EyeWriter tags hold 3 to 6 time stamps a stroke: their 'recorded peaks' were
    matched no better than chance, and nothing said why."""
    def agreement(name: str, points: int) -> dict:
        line = [(0.1 + 0.8 * i / (points - 1), 0.5 + 0.1 * math.sin(3 * i / points), 40.0 * i)
                for i in range(points)]
        return _agreement_of(tmp_path, name, [line])

    assert "a median of 4 time stamps each, too few" in agreement("sparse.gml", 4)["note"]
    assert "note" not in agreement("dense.gml", 40)


def test_a_stroke_whose_time_stamps_span_ages_is_left_out(tmp_path):
    """Fuzzing: one <t> of 1e12 asked for petabytes of speed samples (a traceback), 1e9
    hung the fit's end. Such a stroke is left out of the comparison, and said."""
    wave = [(0.1 + 0.01 * i, 0.5 + 0.1 * math.sin(i / 5)) for i in range(60)]
    low = [(x, y + 0.3) for x, y in wave]
    wild = [5.0 * i for i in range(60)]
    wild[30] = 1e12
    got = _agreement_of(tmp_path, "wild.gml",
                        _timed((wave, low), [[5.0 * i for i in range(60)], wild]))
    assert got["strokes_paired"] == 1 and got["strokes_untimed"] == 1
    assert "span more than 1 h (stroke 2)" in got["note"]
