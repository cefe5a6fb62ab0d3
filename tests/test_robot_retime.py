"""The joint reference within the connected arm's limits by construction (retime.py), and
the Panda/FR3 limit tables it uses."""

from __future__ import annotations

import numpy as np
import pytest

from inkmotion.errors import InputError
from inkmotion.robot.kinematics import pen_model, pen_poses
from inkmotion.robot.limits import FR3, PANDA, arm_limits
from inkmotion.robot.retime import fit_to_limits, padded_ratios
from inkmotion.robot.types import CartesianTrajectory, JointTrajectory

HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
RATE = 1000.0


def program(duration: float, amplitude: np.ndarray, home: np.ndarray = HOME
            ) -> tuple[CartesianTrajectory, JointTrajectory]:
    """A rest-to-rest joint motion (a cosine bump and back) and its pen path."""
    t = np.arange(int(duration * RATE) + 1) / RATE
    s = 0.5 * (1 - np.cos(2 * np.pi * t / duration))
    q = home + np.outer(s, amplitude)
    tip, _ = pen_poses(pen_model(0.15), q)
    n = len(t)
    cart = CartesianTrajectory(t, tip, np.ones(n, bool), np.zeros(n, int),
                               np.array([0.0, 0.0, 1.0]), RATE)
    return cart, JointTrajectory(t, q, RATE, 0.0, 0.0)


def test_a_plan_perturbed_beyond_the_limits_is_retimed_inside_them() -> None:
    # fast enough that the unconstrained reference breaks velocity and acceleration limits
    cart, joints = program(0.6, np.array([0.6, 0.3, 0.0, 0.5, 0.8, 0.6, 0.0]))
    before = padded_ratios(joints.q, RATE, FR3)
    assert max(before["velocity"].max(), before["acceleration"].max()) > 1.0
    cart2, joints2, info = fit_to_limits(cart, joints, FR3, fraction=0.9, position_margin=0.05)
    after = padded_ratios(joints2.q, RATE, FR3)
    assert info["retimed"] and info["retime_factor"] > 1.0
    for name, ratio in after.items():
        assert ratio.max() <= 0.9, name
    assert info["min_margin"] >= 0.1
    # the path is the same: the retimed pen tips lie on the planned ones
    tips, _ = pen_poses(pen_model(0.15), joints2.q)
    assert np.abs(tips - cart2.position).max() < 1e-5
    assert len(joints2.t) == len(cart2.t) and joints2.t[-1] == pytest.approx(
        joints.t[-1] * info["retime_factor"], abs=2e-3)


def test_a_reference_within_the_limits_is_kept_bit_for_bit() -> None:
    cart, joints = program(20.0, np.array([0.1, 0.05, 0.0, 0.1, 0.1, 0.1, 0.0]))
    cart2, joints2, info = fit_to_limits(cart, joints, PANDA, fraction=0.9,
                                         position_margin=0.05)
    assert not info["retimed"] and joints2.q is joints.q and cart2 is cart


def test_the_fr3s_own_position_range_refuses_what_the_panda_allows() -> None:
    # joint 6 at 0.3 rad: inside the Panda's range, below the FR3's 0.5445 rad
    home = HOME.copy()
    home[5] = 0.3
    cart, joints = program(20.0, np.zeros(7), home=home)
    fit_to_limits(cart, joints, PANDA, fraction=0.9, position_margin=0.05)
    with pytest.raises(InputError, match="joint 6 of the fr3"):
        fit_to_limits(cart, joints, FR3, fraction=0.9, position_margin=0.05)


def test_the_arm_models_are_known_by_name() -> None:
    assert arm_limits("FR3") is FR3 and arm_limits("panda") is PANDA
    assert np.all(FR3.acceleration <= PANDA.acceleration.max())
    with pytest.raises(InputError, match="unknown Franka model 'ur5'"):
        arm_limits("ur5")


def test_a_retimed_program_s_timing_figures_are_the_arm_s() -> None:
    """report.json's timing block kept the first timing's total, peaks and sample count
    after a slow-down (19.7 s of "total_s" for a 102 s program)."""
    cart, joints = program(0.6, np.array([0.6, 0.3, 0.0, 0.5, 0.8, 0.6, 0.0]))
    cart.info.update(total_s=0.6, drawing_s=0.4, transfer_s=0.2, time_scale=2.0,
                     peak_speed=1.0, peak_acc=4.0, samples=len(cart.t))
    cart2, joints2, info = fit_to_limits(cart, joints, FR3, fraction=0.9, position_margin=0.05)
    k = info["retime_factor"]
    assert k > 1.0 and cart2.info["retime_factor"] == k
    assert cart2.info["total_s"] == pytest.approx(0.6 * k)
    assert cart2.info["drawing_s"] + cart2.info["transfer_s"] == pytest.approx(0.6 * k)
    assert cart2.info["time_scale"] == pytest.approx(2.0 * k)
    assert cart2.info["peak_speed"] == pytest.approx(1.0 / k)
    assert cart2.info["peak_acc"] == pytest.approx(4.0 / k**2)
    assert cart2.info["samples"] == len(cart2.t) == len(joints2.t)
