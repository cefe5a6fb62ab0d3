"""The 'draw' job kind on franky-sim (a libfranka-protocol FR3 in MuJoCo, started here on
loopback): a fitted word drawn end to end, the checks that refuse before moving, and the
faults the simulator can produce (no robot, Ctrl-C, SIGTERM, a lost connection), each one
sentence with the arm left stopped and nothing half-written in the job folder."""

from __future__ import annotations

import gc
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from franky_fixtures import CONNECT_S, franky_sim_server, require_franky, sim_address

from inkmotion.errors import InputError, ServiceError
from inkmotion.jobs.shell import run_job
from inkmotion.jobs.spec import JobSpec
from inkmotion.robot import franka

ROOT = Path(__file__).resolve().parents[1]
PLAN = ROOT / "tests" / "data" / "v4_jobs" / "fit" / "plan.json"  # a fitted Hershey word
FAST = {"realtime": "ignore", "max_approach": 1.2, "approach_speed": 0.3}

pytestmark = pytest.mark.services


def spec(address: str, **params: object) -> JobSpec:
    return JobSpec(kind="draw", inputs={"plan": str(PLAN)},
                   params={"robot": address, **FAST, **params})


def arm_state(address: str) -> tuple[np.ndarray, np.ndarray]:
    with franka.scheduling_kept():
        robot = franka.connect(address, realtime=False, timeout=CONNECT_S)
        q, dq = np.array(robot.current_joint_positions), np.array(robot.current_joint_velocities)
        del robot
    return q, dq


def move_arm(address: str, q: np.ndarray) -> None:
    import franky

    with franka.scheduling_kept():
        robot = franka.connect(address, realtime=False, timeout=CONNECT_S)
        robot.move(franky.JointMotion(np.asarray(q, dtype=float), relative_dynamics_factor=0.3))
        time.sleep(0.5)
        del robot


HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> str:
    address = sim_address(2)
    with franky_sim_server(address, tmp_path_factory.mktemp("franky") / "sim.log"):
        yield address


@pytest.mark.slow
def test_a_fitted_word_is_drawn_and_the_robots_states_follow_the_plan(sim: str,
                                                                      tmp_path: Path) -> None:
    out = tmp_path / "drawn"
    report = run_job(spec(sim, v_max=0.15), out)
    assert report["completed"] and report["robot"]["model"] == "fr3"
    gc.collect()  # the drawing's record (a cycle through franky's motion) is not kept alive
    assert not [o for o in gc.get_objects() if type(o) is franka._Stream]
    for name in ("executed.csv", "joints.csv", "cartesian.csv", "side_by_side.png",
                 "robot_drawing.png", "plan_drawing.png", "report.json", "setup.toml"):
        assert (out / name).is_file(), name
    # recomputed here from the files: flange by Pinocchio's forward kinematics of the robot's
    # reported joints against that of the plan at the robot's clock
    from inkmotion.robot.kinematics import pen_model, pen_poses

    header = (out / "executed.csv").read_text().splitlines()[0].split(",")
    assert header[:8] == ["t"] + [f"q{i}" for i in range(1, 8)] and header[-3:] == ["x", "y", "z"]
    executed = np.loadtxt(out / "executed.csv", delimiter=",", skiprows=1)
    plan = np.loadtxt(out / "joints.csv", delimiter=",", skiprows=1)
    t, q = executed[:, 0], executed[:, 1:8]
    assert len(t) >= 0.95 * plan[-1, 0] * 1000  # one row per 1 kHz cycle
    k = np.clip(np.round(t * 1000).astype(int), 0, len(plan) - 1)
    inside = t <= plan[-1, 0]
    flange = pen_model(0.0)
    measured = pen_poses(flange, q[inside])[0]
    err = np.linalg.norm(measured - pen_poses(flange, plan[k[inside], 1:])[0], axis=1)
    rms, worst = 1e3 * np.sqrt(np.mean(err**2)), 1e3 * err.max()
    figures = report["robot"]
    print(f"flange tracking on franky-sim: RMS {rms:.3f} mm, max {worst:.3f} mm (report: "
          f"{figures['flange_rms_mm']:.3f}, {figures['flange_max_mm']:.3f})")
    assert rms <= 1.0 and worst <= 3.0
    assert rms == pytest.approx(report["robot"]["flange_rms_mm"], rel=1e-6)
    assert report["robot"]["reported_joint_velocity_min_margin"] > 0
    assert report["planning"]["limits"]["min_margin"] >= 0.1  # φ = 0.9 of the FR3's limits
    _, dq = arm_state(sim)
    assert np.abs(dq).max() < 0.01  # at rest


def test_a_dry_run_checks_everything_and_does_not_move(sim: str, tmp_path: Path) -> None:
    before, _ = arm_state(sim)
    scheduling = os.sched_getscheduler(0), os.sched_getparam(0)
    report = run_job(spec(sim, dry_run=True), tmp_path / "dry")
    # libfranka raised this thread to SCHED_FIFO 99; the job gave it its own policy back
    assert (os.sched_getscheduler(0), os.sched_getparam(0)) == scheduling
    after, _ = arm_state(sim)
    assert report["dry_run"] and report["robot"]["model"] == "fr3"
    assert not (tmp_path / "dry" / "executed.csv").exists()
    assert np.abs(after - before).max() < 2e-3


@pytest.mark.parametrize("host, said", [
    # nothing listens there: refused at once (it said "no robot answered within 10 s")
    ("127.0.0.9", r"The machine at 127\.0\.0\.9 refused the connection at once: it is up, "
                  r"but no FCI listens there"),
    ("no.such.host.invalid", r"The robot's address no\.such\.host\.invalid does not "
                             r"resolve to any machine"),
])
def test_no_robot_at_the_address_is_one_sentence_within_ten_seconds(tmp_path: Path,
                                                                    host: str,
                                                                    said: str) -> None:
    require_franky()
    started = time.monotonic()
    with pytest.raises(ServiceError, match=said):
        run_job(spec(host), tmp_path / "none")
    assert time.monotonic() - started < 12
    assert not (tmp_path / "none").exists()


@pytest.mark.parametrize("problem, params, message", [
    ("start too far", {"max_approach": 0.2}, "from the drawing's start pose"),
    ("plane out of reach", {"setup": "FAR"}, "out of the Panda's reach"),
])
def test_a_plan_that_cannot_be_drawn_is_refused_before_moving(sim: str, tmp_path: Path,
                                                              problem: str, params: dict,
                                                              message: str) -> None:
    if params.get("setup") == "FAR":
        from inkmotion.robot.setup import DEFAULT_SETUP

        text = DEFAULT_SETUP.read_text().replace("[0.415, ", "[1.415, ").replace(
            "[0.205, ", "[1.205, ")
        (tmp_path / "far.toml").write_text(text)
        params = {"setup": str(tmp_path / "far.toml")}
    else:
        move_arm(sim, HOME + np.array([0.0, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0]))
    before, _ = arm_state(sim)
    with pytest.raises(InputError, match=message):
        run_job(spec(sim, **params), tmp_path / "refused")
    after, _ = arm_state(sim)
    assert np.abs(after - before).max() < 2e-3, problem
    assert not (tmp_path / "refused").exists()


def _draw_in_subprocess(address: str, out: Path) -> subprocess.Popen:
    args = [sys.executable, "-m", "inkmotion", "run", "draw", str(PLAN), "--robot", address,
            "--realtime", "ignore", "--max-approach", "1.2", "--approach-speed", "0.3",
            "--no-record", "--out", str(out)]
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})


def _wait_until_drawing(proc: subprocess.Popen, out: Path, seconds: float = 60) -> None:
    """The joints.csv of the staged job appears just before the approach; the drawing
    starts a second or two later."""
    deadline = time.monotonic() + seconds
    while not list(out.parent.glob(f"{out.name}.partial-*/joints.csv")):
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline
        time.sleep(0.1)
    time.sleep(6.0)


@pytest.mark.slow
@pytest.mark.parametrize("signum, reason", [(signal.SIGINT, "interrupted \\(Ctrl-C\\)"),
                                            (signal.SIGTERM, "stopped by SIGTERM")])
def test_a_signal_mid_drawing_stops_the_arm_smoothly_and_keeps_the_record(
        sim: str, tmp_path: Path, signum: int, reason: str) -> None:
    out = tmp_path / "signal"
    proc = _draw_in_subprocess(sim, out)
    _wait_until_drawing(proc, out)
    proc.send_signal(signum)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1
    lines = [line for line in stderr.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "The drawing stopped at" in lines[0], stderr
    import re

    assert re.search(reason, lines[0])
    assert not out.exists()  # nothing that looks complete
    record = json.loads((tmp_path / "signal.stopped" / "report.json").read_text())
    assert record["completed"] is False and 0 < record["stopped_at_s"] < record["of_s"]
    rows = np.loadtxt(tmp_path / "signal.stopped" / "executed.csv", delimiter=",", skiprows=1)
    assert len(rows) > 1000
    _, dq = arm_state(sim)
    assert np.abs(dq).max() < 0.02  # left stopped


@pytest.mark.slow
def test_a_lost_connection_mid_drawing_is_reported(tmp_path: Path) -> None:
    out = tmp_path / "lost"
    address = sim_address(3)
    with franky_sim_server(address, tmp_path / "sim.log") as server:
        proc = _draw_in_subprocess(address, out)
        _wait_until_drawing(proc, out)
        server.kill()
        server.wait()
        _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert "the connection to the robot was lost" in stderr, stderr
    assert not out.exists()
    assert (tmp_path / "lost.stopped" / "executed.csv").is_file()
