"""`inkmotion robot teach` on franky-sim: the simulated FR3 is pushed to four poses (a
"hand": torques added in MuJoCo before each step, while the command keeps the arm floating),
Enter is typed at each, and the setup it writes holds those four pen-tip corners."""

from __future__ import annotations

import subprocess
import sys
import time
import types
from pathlib import Path

import numpy as np
import pytest
from franky_fixtures import require_franky

pytestmark = pytest.mark.services

HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


def corner_poses() -> tuple[np.ndarray, np.ndarray]:
    """Joint poses (4, 7) whose pen tips are the default setup's four corners."""
    from inkmotion.robot.joints import solve_joint_trajectory
    from inkmotion.robot.limits import FR3
    from inkmotion.robot.setup import load_setup

    setup = load_setup()
    poses = []
    for corner in setup.plane_points:
        target = types.SimpleNamespace(t=np.zeros(1), position=corner[None],
                                       normal=setup.plane.normal, rate=1000.0)
        poses.append(solve_joint_trajectory(target, pen_length=setup.pen_length, home=HOME,
                                            joint_margin=0.1,
                                            position_limits=(FR3.lower, FR3.upper)).q[0])
    return np.array(poses), setup.plane_points


def test_teaching_four_corners_writes_a_setup_with_that_plane(tmp_path: Path) -> None:
    require_franky()
    from franky_sim import SimulationServer
    from franky_sim.mujoco_simulator import MujocoSimulator

    from inkmotion.robot.setup import load_setup

    poses, corners = corner_poses()
    hand: dict[str, np.ndarray | None] = {"target": None}
    out = tmp_path / "bench.toml"
    with MujocoSimulator(enable_visualization=False) as sim:
        arm = sim.add_robot(initial_q=tuple(HOME))
        with SimulationServer(sim, hostname_candidates=["127.0.0.4"]) as server:
            def push(s: object) -> None:  # a hand on the arm: runs inside every sim step
                if hand["target"] is None:
                    return
                q, dq = np.array(arm.inner_state.q), np.array(arm.inner_state.dq)
                tau = np.clip(400.0 * (hand["target"] - q) - 30.0 * dq, -40, 40)
                for i, address in enumerate(arm._dof_addrs):
                    s.data.qfrc_applied[address] += tau[i]

            sim.register_pre_step_callback(push)
            server.run_async(realtime=1.0)
            proc = subprocess.Popen(
                [sys.executable, "-m", "inkmotion", "robot", "teach", "--robot", "127.0.0.4",
                 "--realtime", "ignore", "--out", str(out)],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                text=True)
            try:
                time.sleep(3.0)  # connected and floating
                for pose in poses:
                    hand["target"] = pose
                    deadline = time.monotonic() + 8.0
                    while (np.abs(np.array(arm.inner_state.q) - pose).max() > 2e-3
                           and time.monotonic() < deadline):
                        time.sleep(0.05)
                    proc.stdin.write("\n")
                    proc.stdin.flush()
                    time.sleep(0.3)
                hand["target"] = None
                _, stderr = proc.communicate(timeout=30)
            finally:
                if proc.poll() is None:
                    proc.kill()
    assert proc.returncode == 0, stderr
    assert "plane taught" in stderr and "corner" in stderr
    taught = load_setup(out)
    error = np.linalg.norm(taught.plane_points - corners, axis=1)
    print(f"taught corners off the intended ones by {1e3 * error.max():.2f} mm at most")
    assert error.max() < 3e-3
    assert taught.paper == pytest.approx((0.297, 0.21), abs=4e-3)


def test_teach_refuses_to_replace_a_file(tmp_path: Path) -> None:
    out = tmp_path / "bench.toml"
    out.write_text("keep me")
    res = subprocess.run([sys.executable, "-m", "inkmotion", "robot", "teach", "--robot",
                          "127.0.0.9", "--out", str(out)], capture_output=True, text=True)
    assert res.returncode == 1 and "exists" in res.stderr and out.read_text() == "keep me"
