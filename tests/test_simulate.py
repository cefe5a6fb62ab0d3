"""End-to-end: the 'simulate' job kind through the real command line — setup, timing,
joint trajectory on Pinocchio's Panda, execution in MuJoCo, export — on a fitted plan."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "gml"
ARTIFACTS = {"joints.csv", "cartesian.csv", "executed.csv", "setup.toml", "sim_drawing.png",
             "plan_drawing.png", "side_by_side.png", "job.json", "report.json",
             "recording.rrd"}


def inkmotion(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=600, env=env)


@pytest.fixture(scope="module")
def fitted_plan(tmp_path_factory) -> Path:
    """A fitted tag when ../shared is there (the issue's case), else a fitted word."""
    out = tmp_path_factory.mktemp("fit") / "fit"
    tag = SHARED / "49873.json"
    source, steps = (str(tag), "150") if tag.is_file() else ("text:hi", "60")
    res = inkmotion("run", "fit", source, "--out", str(out), "--steps", steps, "--no-record")
    assert res.returncode == 0, res.stderr
    return out / "plan.json"


@pytest.fixture(scope="module")
def simulated(fitted_plan: Path, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("sim") / "sim"
    res = inkmotion("run", "simulate", str(fitted_plan), "--v-max", "0.25", "--backend",
                    "franka-sim", "--backend", "export", "--export-rate", "250",
                    "--out", str(out))
    assert res.returncode == 0, res.stderr
    return out


def test_simulation_writes_every_artifact(simulated: Path) -> None:
    assert ARTIFACTS <= {p.name for p in simulated.iterdir()}
    joints = np.loadtxt(simulated / "joints.csv", delimiter=",", skiprows=1)
    cart = np.loadtxt(simulated / "cartesian.csv", delimiter=",", skiprows=1)
    assert joints.shape[1] == 8 and cart.shape[1] == 5 and len(joints) == len(cart)
    assert np.allclose(np.diff(joints[:, 0]), 1e-3)  # the 1 kHz control rate
    assert (simulated / "cartesian.csv").read_text().startswith("t,x,y,z,pen_down")
    assert (simulated / "executed.csv").read_text().startswith("t,x,y,z,contact")


def test_tracking_limits_and_coverage(simulated: Path) -> None:
    """The issue's figures: MuJoCo tracking RMS < 2 mm at v_max = 0.25 m/s, the joint
    trajectory inside the limits with pen error < 0.5 mm and < 2°, the pen on the paper."""
    report = json.loads((simulated / "report.json").read_text())
    sim = report["franka-sim"]
    joints = report["joint_trajectory"]
    assert sim["tracking_down_plane_rms_mm"] < 2.0
    assert joints["max_position_error_mm"] < 0.5
    assert joints["max_orientation_error_deg"] < 2.0
    assert joints["min_joint_margin"] > 0
    assert max(joints["max_velocity_ratio"]) < 1 and max(joints["max_acceleration_ratio"]) < 1
    assert sim["commanded_joint_velocity_min_margin"] > 0
    assert sim["executed_joint_velocity_min_margin"] > 0
    assert sim["contact_coverage"] > 0.95 and sim["spurious_contact"] < 0.05
    assert report["timing"]["peak_speed"] <= 0.25 * 1.001
    assert report["setup"]["v_max"] == 0.25
    assert sim["real_time_factor"] > 1


def test_sim_drawing_matches_the_plan(simulated: Path) -> None:
    import cv2

    plan = cv2.imread(str(simulated / "plan_drawing.png"), cv2.IMREAD_GRAYSCALE) < 128
    sim = cv2.imread(str(simulated / "sim_drawing.png"), cv2.IMREAD_GRAYSCALE) < 128
    assert plan.shape == sim.shape and sim.any()
    near = cv2.dilate(plan.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
    assert sim[near].sum() / sim.sum() > 0.97  # the simulated ink lies on the planned ink


def test_export_has_its_header_and_rate(simulated: Path) -> None:
    text = (simulated / "export" / "joints_250Hz.csv").read_text()
    header = json.loads("\n".join(line[2:] for line in text.splitlines() if line[:1] == "#"))
    assert header["rate_hz"] == 250 and "v_max" in header["setup_toml"]
    assert len(header["calibration"]["plane_rotation"]) == 3
    lines = [line for line in text.splitlines() if line[:1] != "#"]
    assert lines[0] == "t,q1,q2,q3,q4,q5,q6,q7"
    data = np.loadtxt(lines[1:], delimiter=",")
    assert data.shape[1] == 8 and np.allclose(np.diff(data[:, 0]), 1 / 250)


def test_recording_replays_the_arm(simulated: Path) -> None:
    from inkmotion.recording import entity_paths

    paths = set(entity_paths(simulated / "recording.rrd"))
    assert "/robot/links/panda_link4" in paths or "robot/links/panda_link4" in paths
    assert any("contact_trace" in p for p in paths) and any("pen_tip" in p for p in paths)


def test_unreachable_plane_is_refused_before_any_motion(fitted_plan: Path,
                                                        tmp_path: Path) -> None:
    from inkmotion.robot.setup import DEFAULT_SETUP

    text = DEFAULT_SETUP.read_text().replace("0.415,", "2.415,").replace("0.205,", "2.205,")
    far = tmp_path / "far.toml"
    far.write_text(text)
    out = tmp_path / "never"
    res = inkmotion("run", "simulate", str(fitted_plan), "--setup", str(far), "--out",
                    str(out))
    assert res.returncode != 0 and "Traceback" not in res.stderr
    assert "reach" in res.stderr.lower()
    assert not out.exists()


def test_bad_setup_file_names_the_key(fitted_plan: Path, tmp_path: Path) -> None:
    from inkmotion.robot.setup import DEFAULT_SETUP

    bad = tmp_path / "bad.toml"
    bad.write_text(DEFAULT_SETUP.read_text().replace("v_max = 0.25", 'v_max = "fast"'))
    res = inkmotion("run", "simulate", str(fitted_plan), "--setup", str(bad), "--out",
                    str(tmp_path / "o"))
    assert res.returncode != 0 and str(bad) in res.stderr and "v_max" in res.stderr


@pytest.mark.parametrize("old, new, key", [
    ("contact_offset = -0.0003", "contact_offset = -0.02", "contact_offset"),
    ("v_max = 0.25", "v_max = 10.0", "v_max"),
    ("a_max = 2.5", "a_max = 100.0", "a_max"),
])
def test_a_setup_beyond_what_the_arm_and_pen_can_use_is_refused(fitted_plan: Path,
                                                                 tmp_path: Path, old: str,
                                                                 new: str, key: str) -> None:
    """A 20 mm press drew 13 mm off the plan with 47 N on the board, and a setup's v_max of
    10 m/s (the CLI refuses 5) drove the joints 35 % past their jerk limit: both ran to a
    plain "done"."""
    from inkmotion.robot.setup import DEFAULT_SETUP

    bad = tmp_path / "bench.toml"
    bad.write_text(DEFAULT_SETUP.read_text().replace(old, new))
    out = tmp_path / "never"
    res = inkmotion("run", "simulate", str(fitted_plan), "--setup", str(bad), "--out",
                    str(out), "--no-record")
    assert res.returncode != 0 and "Traceback" not in res.stderr
    assert f"{bad}: [" in res.stderr and key in res.stderr and "is outside" in res.stderr
    assert not out.exists()


def test_a_plan_whose_strokes_leave_its_canvas_says_the_pen_leaves_the_paper(
        fitted_plan: Path, tmp_path: Path) -> None:
    plan = json.loads(fitted_plan.read_text())
    plan["canvas"]["height"] *= 0.3
    cut = tmp_path / "cut.json"
    cut.write_text(json.dumps(plan))
    out = tmp_path / "sim"
    res = inkmotion("run", "simulate", str(cut), "--out", str(out), "--no-record",
                    "--backend", "export")
    assert res.returncode == 0, res.stderr
    report = json.loads((out / "report.json").read_text())
    assert any("beyond the paper" in w for w in report["warnings"]), report.get("warnings")
    assert "beyond the paper" in res.stderr


def test_an_execution_that_strays_or_passes_a_limit_is_said():
    from inkmotion.kinds.simulate import execution_warnings

    good = {"tracking_down_plane_max_mm": 0.3, "tracking_down_plane_rms_mm": 0.27,
            "executed_joint_velocity_min_margin": 0.5,
            "executed_joint_acceleration_min_margin": 0.3,
            "executed_joint_jerk_min_margin": 0.1, "contact_force_max_n": 12.0}
    assert execution_warnings("franka-sim", good) == []
    bad = {**good, "tracking_down_plane_max_mm": 13.6, "tracking_down_plane_rms_mm": 12.7,
           "contact_force_max_n": 46.8, "executed_joint_jerk_min_margin": -1.97,
           "executed_joint_acceleration_min_margin": -0.127}
    said = execution_warnings("franka-sim", bad)
    assert len(said) == 2
    assert "13.6 mm off the plan" in said[0] and "47 N" in said[0]
    assert "acceleration and jerk limit (by 197 %" in said[1]
