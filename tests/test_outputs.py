"""Output writers: SVG, PNG/overlay, trajectory CSV, speed plot, atomic staging."""

import csv
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from inkmotion import MotorPlan, bezier_segments
from inkmotion.outputs import (
    StagingDir,
    write_overlay,
    write_png,
    write_speed_plot,
    write_svg,
    write_trajectory_csv,
)

SVG = "{http://www.w3.org/2000/svg}"
SPEED_SIZE = (1200, 384)  # speed.png, width × height


def _plans(dim: int = 2) -> list[MotorPlan]:
    a = [[20.0, 20.0], [120.0, 40.0], [60.0, 150.0], [180.0, 170.0]]
    b = [[200.0, 30.0], [260.0, 90.0], [210.0, 160.0]]
    if dim == 3:
        a = [p + [2.0 + i] for i, p in enumerate(a)]
        b = [p + [1.0] for p in b]
    plans = [MotorPlan.from_points(a, dtype=torch.float64),
             MotorPlan.from_points(b, dtype=torch.float64, width=5.0)]
    plans[0].delta = torch.tensor([0.5, -0.3, 0.0], dtype=torch.float64)
    plans[0].delta_t = torch.tensor([1.0, 0.5, 0.4], dtype=torch.float64)
    return plans


def _bezier_length(seg: torch.Tensor, k: int = 200) -> float:
    t = torch.linspace(0, 1, k + 1, dtype=torch.float64)[:, None, None]
    p = seg[None, :, :, :2].to(torch.float64)  # (1, S, 4, 2)
    c = ((1 - t) ** 3 * p[:, :, 0] + 3 * (1 - t) ** 2 * t * p[:, :, 1]
         + 3 * (1 - t) * t**2 * p[:, :, 2] + t**3 * p[:, :, 3])  # (k+1, S, 2)
    return float(torch.linalg.vector_norm(c.diff(dim=0), dim=-1).sum())


def test_svg(tmp_path: Path) -> None:
    plans = _plans()
    segs = [bezier_segments(p).detach() for p in plans]
    out = tmp_path / "drawing.svg"
    write_svg(out, segs, [p.width for p in plans], (300.0, 200.0))
    root = ET.parse(out).getroot()
    assert root.tag == f"{SVG}svg" and root.get("version") == "1.1"
    assert root.get("width") == "300px" and root.get("height") == "200px"
    assert root.get("viewBox") == "0 0 300 200"
    paths = root.findall(f".//{SVG}path")
    assert len(paths) == 2
    assert [float(p.get("stroke-width")) for p in paths] == [3.0, 5.0]
    d = paths[0].get("d")
    assert d.startswith("M ") and d.count("C ") == segs[0].shape[0]
    svgelements = pytest.importorskip("svgelements")
    doc = svgelements.SVG.parse(str(out))
    elements = [e for e in doc.elements() if isinstance(e, svgelements.Path)]
    assert len(elements) == 2
    for e, s in zip(elements, segs, strict=True):
        assert e.length() == pytest.approx(_bezier_length(s), rel=1e-3)


def test_png_and_overlay(tmp_path: Path) -> None:
    img = torch.zeros(40, 60)
    img[10:20, 5:50] = 1.0
    write_png(tmp_path / "a.png", img)
    a = cv2.imread(str(tmp_path / "a.png"), cv2.IMREAD_UNCHANGED)
    assert a.shape == (40, 60) and a.dtype == np.uint8
    assert a[15, 20] == 0 and a[0, 0] == 255

    target = torch.zeros(40, 60)
    target[12:22, 5:50] = 1.0
    pos = torch.tensor([[5.0, 15.0], [50.0, 15.0]])
    write_overlay(tmp_path / "o.png", target, img, traces=[np.array([[5, 17], [50, 17]])],
                  positions=[pos])
    o = cv2.imread(str(tmp_path / "o.png"), cv2.IMREAD_COLOR)
    assert o.shape == (40, 60, 3)
    assert tuple(o[0, 0]) == (255, 255, 255)
    b, g, r = (int(v) for v in o[21, 30])  # target only: reddish
    assert r > b and r > 200
    b, g, r = (int(v) for v in o[11, 30])  # result only: bluish
    assert b > r and b > 100


@pytest.mark.parametrize("dim", [2, 3])
def test_trajectory_csv(tmp_path: Path, dim: int) -> None:
    plans = _plans(dim)
    out = tmp_path / "trajectory.csv"
    write_trajectory_csv(out, plans, samples_per_move=10)
    rows = list(csv.reader(out.open()))
    expected = ["path", "t", "x", "y"] + (["r"] if dim == 3 else []) + [
        "vx", "vy", "ax", "ay", "speed"]
    assert rows[0] == expected
    body = rows[1:]
    assert len(body) == sum(10 * p.m + 1 for p in plans)
    assert {r[0] for r in body} == {"0", "1"}
    first = [float(v) for v in body[0][1:]]
    # t = 0 is the start of the first ±3σ window: Φ(−3) ≈ 0.13 % of d_1 is already done
    assert first[0] == 0.0 and first[1:3] == pytest.approx([20.0, 20.0], abs=0.3)
    last0 = [float(v) for v in body[10 * plans[0].m][1:]]
    assert last0[1:3] == pytest.approx([180.0, 170.0], abs=0.3)
    vx, vy, speed = (float(body[5][expected.index(k)]) for k in ("vx", "vy", "speed"))
    assert speed == pytest.approx(math.hypot(vx, vy), rel=1e-6)


def test_speed_plot(tmp_path: Path) -> None:
    out = tmp_path / "speed.png"
    write_speed_plot(out, _plans())
    img = cv2.imread(str(out), cv2.IMREAD_COLOR)
    assert img is not None and img.shape[:2] == SPEED_SIZE[::-1]


def _speed_plot_rows(plans: list[MotorPlan], tmp_path: Path) -> tuple[np.ndarray, tuple]:
    from inkmotion.outputs.chart import MARGINS

    write_speed_plot(tmp_path / "speed.png", plans)
    img = cv2.imread(str(tmp_path / "speed.png"), cv2.IMREAD_COLOR).astype(int)
    left, top, right, bottom = MARGINS
    width, height = SPEED_SIZE
    return img[top + 2:height - bottom - 2, left + 2:width - right - 2], (top, height - bottom)


def test_speed_plot_draws_the_peak_where_the_axis_says(tmp_path: Path) -> None:
    """One straight move: the black curve's highest ink is at its peak speed, which the
    axis puts at 1/1.05 of its height; the blue bell of its only move lies under it."""
    plan = MotorPlan.from_points([[0.0, 0.0], [200.0, 0.0]], dtype=torch.float64)
    inside, (top, bottom) = _speed_plot_rows([plan], tmp_path)
    black = (inside.max(axis=2) < 90).any(axis=1)
    peak_row = top + 2 + int(np.argmax(black))
    expected = bottom - (bottom - top) / 1.05
    assert abs(peak_row - expected) <= 2.5, (peak_row, expected)
    blue = (inside[..., 0] - inside[..., 2] > 60).any(axis=1)  # B well over R
    assert blue.sum() > 0.5 * len(blue)


def test_speed_plot_bands_every_other_path(tmp_path: Path) -> None:
    """Three paths: the second lies on a faint grey band, the first and third do not."""
    plans = [MotorPlan.from_points([[0.0, 0.0], [100.0 + 50 * k, 0.0]], dtype=torch.float64)
             for k in range(3)]
    inside, _ = _speed_plot_rows(plans, tmp_path)
    top_row = inside[2]  # above every curve: only bands or white
    grey = np.all(np.abs(top_row - 240) <= 2, axis=1)
    runs = np.flatnonzero(np.diff(grey.astype(int)))
    assert grey.any() and len(runs) == 2, runs  # one band, inside the box
    band = slice(runs[0] + 1, runs[1] + 1)
    ends = np.cumsum([float(p.end_time) for p in plans])
    gap = 0.03 * ends[-1] + 1e-3
    x_of = (inside.shape[1] + 4) / (ends[-1] + 2 * gap)  # px a second
    assert abs((band.start + 2) - (ends[0] + gap) * x_of) <= 3
    assert abs((band.stop + 2) - (ends[1] + gap) * x_of) <= 3


def test_fit_job_does_not_import_matplotlib(tmp_path: Path) -> None:
    """A fit's outputs are drawn with OpenCV: matplotlib's import and first figure are a
    sixth of a short fit's time, which a one-off ``inkmotion run fit`` would pay (a timed
    recording adds human_speeds.png, a second chart)."""
    import subprocess
    import sys

    code = ("import sys; from inkmotion.jobs.spec import JobSpec; "
            "from inkmotion.jobs.shell import run_job; "
            "run_job(JobSpec(kind='fit', inputs={'drawing': 'sample:tempt-1'}, "
            "params={'steps': 4, 'size': 96}), sys.argv[1]); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'matplotlib'))")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert {"speed.png", "human_speeds.png"} <= {p.name for p in (tmp_path / "out").iterdir()}
    assert done.stdout.strip().splitlines()[-1] == "[]"


def test_staging_dir_commit_replaces_atomically(tmp_path: Path) -> None:
    final = tmp_path / "job"
    final.mkdir()
    (final / "old.txt").write_text("old")
    with StagingDir(final) as stage:
        assert stage.path.parent == tmp_path and stage.path.name.startswith("job.partial-")
        (stage.path / "new.txt").write_text("new")
        assert (final / "old.txt").exists()  # untouched until commit
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job"]
    assert sorted(p.name for p in final.iterdir()) == ["new.txt"]


def test_staging_dir_cleanup_on_exception(tmp_path: Path) -> None:
    final = tmp_path / "out" / "job"
    with pytest.raises(RuntimeError), StagingDir(final) as stage:
        (stage.path / "half.txt").write_text("x")
        raise RuntimeError("boom")
    assert not final.exists()
    assert list((tmp_path / "out").iterdir()) == []


def test_staging_dir_exception_keeps_existing(tmp_path: Path) -> None:
    final = tmp_path / "job"
    final.mkdir()
    (final / "keep.txt").write_text("keep")
    with pytest.raises(ValueError), StagingDir(final) as stage:
        (stage.path / "x").write_text("x")
        raise ValueError
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job"]
    assert (final / "keep.txt").read_text() == "keep"


def test_a_killed_jobs_staging_folder_is_removed_by_the_next_job(tmp_path: Path) -> None:
    """A process killed outright leaves its DIR.partial-* folder; the next job writing to
    DIR removes it, and leaves a running process's and another host's alone."""
    import subprocess
    import sys

    final = tmp_path / "job"
    killed = subprocess.run(
        [sys.executable, "-c",
         "import os, signal, sys\n"
         "from inkmotion.outputs import StagingDir\n"
         "with StagingDir(sys.argv[1]) as stage:\n"
         "    (stage.path / 'half.txt').write_text('x')\n"
         "    os.kill(os.getpid(), signal.SIGKILL)\n", str(final)], check=False)
    assert killed.returncode == -9
    (left,) = tmp_path.glob("job.partial-*")
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        host = left.name.split("-")[1]
        running = tmp_path / f"job.partial-{host}-{sleeper.pid}-0000"
        elsewhere = tmp_path / "job.partial-otherhost-1-0000"
        other_namespace = tmp_path / f"job.partial-{host}1-1-0000"  # a container's
        running.mkdir()
        elsewhere.mkdir()
        other_namespace.mkdir()
        with StagingDir(final) as stage:
            (stage.path / "new.txt").write_text("new")
        assert not left.exists()
        assert running.exists() and elsewhere.exists() and other_namespace.exists()
        assert sorted(p.name for p in final.iterdir()) == ["new.txt"]
    finally:
        sleeper.kill()
        sleeper.wait()


def test_a_run_that_may_not_replace_keeps_results_written_meanwhile(tmp_path: Path) -> None:
    """Two runs started into the same new --out both succeeded, and the second replaced
    the first without --force. Results another run committed while this one ran are now
    kept, and this run's go to OUT-2, said in a warning."""
    from inkmotion.jobs.shell import run_job
    from inkmotion.jobs.spec import JobSpec

    final = tmp_path / "out"
    with StagingDir(final, replace=False) as stage:
        (stage.path / "mine.txt").write_text("mine")
        final.mkdir()  # the other run commits first
        (final / "theirs.txt").write_text("theirs")
    assert stage.diverted_from == final and stage.final == tmp_path / "out-2"
    assert (final / "theirs.txt").exists() and (tmp_path / "out-2" / "mine.txt").exists()
    with StagingDir(tmp_path / "empty", replace=False) as stage:  # an empty folder: taken
        (tmp_path / "empty").mkdir()
        (stage.path / "mine.txt").write_text("mine")
    assert stage.diverted_from is None and (tmp_path / "empty" / "mine.txt").exists()

    class OtherRunCommits:
        def on_step(self, state: object) -> None:
            if state.step == 3:  # type: ignore[attr-defined]
                (tmp_path / "job").mkdir()
                (tmp_path / "job" / "report.json").write_text("{}")

    spec = JobSpec(kind="fit", inputs={"drawing": "text:hi"}, device="cpu", record_every=0,
                   params={"steps": 5, "size": 80})
    report = run_job(spec, tmp_path / "job", observers=[OtherRunCommits()], replace=False)
    assert report["out_dir"] == str(tmp_path / "job-2")
    assert "was written by another run while this one ran" in report["warnings"][-1]
    assert (tmp_path / "job" / "report.json").read_text() == "{}"
    assert (tmp_path / "job-2" / "plan.json").is_file()


def test_plots_leave_the_processs_matplotlib_as_it_was(tmp_path: Path) -> None:
    """Every plot the jobs write draws on a figure of its own: the backend a notebook or
    a worker chose stays, and no pyplot figure is left open."""
    import matplotlib
    import matplotlib.pyplot as plt

    from inkmotion.evaluation.human import plot_speed_profiles
    from inkmotion.evaluation.plots import plot_minima, plot_speeds
    from inkmotion.evaluation.timings import TimedPath
    from inkmotion.plotter.preview import write_feed_plot, write_preview
    from inkmotion.plotter.timing import PlotStroke

    before = matplotlib.get_backend()
    matplotlib.use("svg")
    try:
        t = np.linspace(0.0, 1.0, 50)
        xy = np.column_stack((100 * t, 40 * np.sin(6 * t)))
        arc = np.linspace(0.0, 1.0, 50)
        speed = np.sin(np.pi * arc) + 0.1
        timed = TimedPath(t, xy, np.gradient(xy, axis=0), np.zeros_like(xy), None, "ΣΛ")
        stroke = PlotStroke(0, 0, xy[:10] / 2, np.full(9, 0.1), np.full(9, 5.0))
        write_speed_plot(tmp_path / "speed.png", _plans())
        plot_speed_profiles(tmp_path / "human.png", [(arc, speed)], [(arc, speed[::-1])])
        plot_speeds(tmp_path / "speeds.png", {"sigma-lognormal": timed}, 0.001)
        plot_minima(tmp_path / "minima.png", xy, 0.02, (120.0, 60.0))
        write_preview(tmp_path / "preview.png", [stroke], (60.0, 40.0), "a stroke")
        write_feed_plot(tmp_path / "feed.png", [stroke])
        assert matplotlib.get_backend() == "svg"
        assert plt.get_fignums() == []
        for name in ("speed", "human", "speeds", "minima", "preview", "feed"):
            assert cv2.imread(str(tmp_path / f"{name}.png")) is not None, name
    finally:
        matplotlib.use(before)
