"""The pen model on Pinocchio's Panda and the joint trajectory solver: pen-tip accuracy and
pen-axis alignment at every control sample, joint limits with margin, the Panda's speed
limits, reachability errors before any solve, determinism, degenerate trajectories."""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from inkmotion.errors import InputError
from inkmotion.robot import limits, panda
from inkmotion.robot.joints import solve_joint_trajectory
from inkmotion.robot.kinematics import check_reachable, pen_jacobians, pen_model, pen_poses
from inkmotion.robot.scene import build_scene
from inkmotion.robot.types import CartesianTrajectory

HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
PEN_LENGTH = 0.1
RATE = 1000.0
UP = np.array([0.0, 0.0, 1.0])
POSITION_TOLERANCE = 5e-4  # m
ORIENTATION_TOLERANCE = np.radians(2.0)


def home_tip() -> np.ndarray:
    return pen_poses(pen_model(PEN_LENGTH), HOME)[0][0]


def min_jerk(n: int) -> np.ndarray:
    """s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on n samples: rest to rest."""
    s = np.linspace(0.0, 1.0, n)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def trajectory(pieces: list, normal: np.ndarray = UP) -> CartesianTrajectory:
    """Rest-to-rest pieces (duration s, curve(s in [0, 1]) -> (n, 3)) joined at 1 kHz."""
    points = []
    for duration, curve in pieces:
        p = curve(min_jerk(int(round(duration * RATE)) + 1))
        points.append(p if not points else p[1:])
    position = np.concatenate(points)
    n = len(position)
    return CartesianTrajectory(t=np.arange(n) / RATE, position=position,
                               pen_down=np.ones(n, bool), stroke=np.zeros(n, int),
                               normal=np.asarray(normal, float), rate=RATE)


def line(a: np.ndarray, b: np.ndarray):
    return lambda s: a + s[:, None] * (b - a)


def lissajous(center: np.ndarray, a: float, b: float, k: tuple[int, int]):
    def curve(s: np.ndarray) -> np.ndarray:
        th = 2 * np.pi * s
        return center + np.stack([a * np.sin(k[0] * th), b * np.sin(k[1] * th), 0 * th], 1)
    return curve


def figure_eight() -> CartesianTrajectory:
    """Down 3 cm from the home pen tip, a 10 cm figure-eight (peak 0.28 m/s), back up."""
    tip = home_tip()
    board = tip - [0.0, 0.0, 0.03]
    return trajectory([(0.5, line(tip, board)), (3.0, lissajous(board, 0.05, 0.025, (1, 2))),
                       (0.5, line(board, tip))])


@pytest.fixture(scope="module")
def eight() -> tuple[CartesianTrajectory, object]:
    target = figure_eight()
    return target, solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME)


def errors(q: np.ndarray, target: CartesianTrajectory) -> tuple[np.ndarray, np.ndarray]:
    """Independent check with Pinocchio's own frame placement of the flange."""
    model = pen_model(PEN_LENGTH).model
    data = model.createData()
    flange = model.getFrameId(panda.FLANGE)
    pos, ang = np.empty(len(q)), np.empty(len(q))
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(model, data, qk)
        pose = data.oMf[flange]
        axis = pose.rotation[:, 2]
        pos[k] = np.linalg.norm(pose.translation + PEN_LENGTH * axis - target.position[k])
        ang[k] = np.arccos(np.clip(-axis @ target.normal, -1.0, 1.0))
    return pos, ang


# --- the pen model ---------------------------------------------------------------------

def test_pen_tip_is_pen_length_along_the_flange_z_axis():
    model = pen_model(PEN_LENGTH).model
    data = model.createData()
    pin.framesForwardKinematics(model, data, HOME)
    flange = data.oMf[model.getFrameId(panda.FLANGE)]
    tip, axis = pen_poses(pen_model(PEN_LENGTH), HOME)
    np.testing.assert_allclose(tip[0], flange.translation + 0.1 * flange.rotation[:, 2],
                               atol=1e-12)
    np.testing.assert_allclose(axis[0], [0.0, 0.0, -1.0], atol=1e-6)  # home: pen down
    assert model.nq == 7


def test_pen_jacobian_matches_finite_differences():
    pen = pen_model(PEN_LENGTH)
    q = HOME + np.array([0.1, -0.2, 0.3, 0.1, -0.2, 0.1, 0.4])
    p, a, jac = pen_jacobians(pen, q[None])
    eps = 1e-7
    for j in range(7):
        dq = np.zeros(7)
        dq[j] = eps
        p1, a1 = pen_poses(pen, (q + dq)[None])
        np.testing.assert_allclose((p1[0] - p[0]) / eps, jac[0, :3, j], atol=1e-6)
        np.testing.assert_allclose((a1[0] - a[0]) / eps, np.cross(jac[0, 3:, j], a[0]),
                                   atol=1e-6)


def test_pen_tip_matches_the_mujoco_scene():
    scene = build_scene(board_origin=np.array([0.4, -0.1, 0.0]), board_rotation=np.eye(3),
                        board_size=(0.2, 0.15), pen_length=0.2)
    data = mujoco.MjData(scene.model)
    rng = np.random.default_rng(0)
    pen = pen_model(0.2)
    for q in rng.uniform(pen.lower, pen.upper, size=(5, 7)):
        data.qpos[scene.qpos_adr] = q
        mujoco.mj_kinematics(scene.model, data)
        tip, axis = pen_poses(pen, q)
        np.testing.assert_allclose(tip[0], data.site_xpos[scene.pen_tip_site], atol=1e-9)
        np.testing.assert_allclose(axis[0], data.site_xmat[scene.pen_tip_site][[2, 5, 8]],
                                   atol=1e-9)


# --- reachability ----------------------------------------------------------------------

def test_check_reachable_accepts_the_drawing():
    check_reachable(figure_eight().position, UP, PEN_LENGTH, joint_margin=0.05)


def test_a_target_two_metres_away_is_refused_before_any_solve(monkeypatch):
    target = figure_eight()
    target.position[1500:] += [2.0, 0.0, 0.0]
    target.stroke[1500:] = 3
    with pytest.raises(InputError, match=r"sample 1500 \(stroke 3\).*move the drawing plane"):
        check_reachable(target.position, UP, PEN_LENGTH, stroke=target.stroke)

    import inkmotion.robot.joints as joints

    def no_solve(*args, **kwargs):
        raise AssertionError("the solver ran on an unreachable target")

    monkeypatch.setattr(joints, "_solve_ik", no_solve)
    with pytest.raises(InputError, match=r"\(2\.\d+, 0\.\d+, 0\.460\) m .* out of the Panda's"):
        solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME)


def test_a_target_inside_the_base_is_refused():
    with pytest.raises(InputError, match="away from the robot's base"):
        check_reachable(np.array([[0.05, 0.0, 0.1]]), UP, PEN_LENGTH)


def test_a_pose_the_precheck_lets_through_is_refused_by_the_solver():
    # 0.9 m above the base with the pen pointing down: the wrist is within reach, but the
    # arm cannot fold over it to hold the pen vertical
    x = np.array([0.0, 0.0, 0.9])
    check_reachable(x[None], UP, PEN_LENGTH, joint_margin=0.05)
    target = trajectory([(0.01, line(x, x))])
    with pytest.raises(InputError, match=r"cannot hold the pen at sample 0 .*0\.900\) m"):
        solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME)


# --- the joint trajectory --------------------------------------------------------------

def test_tracks_the_pen_tip_and_axis_at_every_control_sample(eight):
    target, result = eight
    assert result.q.shape == (len(target.t), 7)
    np.testing.assert_array_equal(result.t, target.t)
    pos, ang = errors(result.q, target)
    assert pos.max() < POSITION_TOLERANCE and ang.max() < ORIENTATION_TOLERANCE
    assert result.max_position_error == pytest.approx(pos.max(), abs=1e-9)
    assert result.max_orientation_error <= ORIENTATION_TOLERANCE
    assert pos.max() < 1e-5  # in fact micrometres


def test_stays_inside_the_joint_limits_with_margin(eight):
    _, result = eight
    pen = pen_model(PEN_LENGTH)
    assert np.all(result.q >= pen.lower + 0.05) and np.all(result.q <= pen.upper - 0.05)
    assert result.info["min_joint_margin"] >= 0.05


def test_respects_the_panda_velocity_acceleration_and_jerk_limits(eight):
    _, result = eight
    dt = 1.0 / RATE
    assert np.all(np.abs(np.diff(result.q, axis=0)) / dt <= limits.VELOCITY_LIMITS)
    for key in ("max_velocity_ratio", "max_acceleration_ratio", "max_jerk_ratio"):
        ratio = np.asarray(result.info[key])
        assert ratio.shape == (7,) and np.all(ratio < 1.0), (key, ratio)
    # starts and ends at rest
    assert np.abs(result.q[1] - result.q[0]).max() / dt < 1e-3
    assert np.abs(result.q[-1] - result.q[-2]).max() / dt < 1e-3


def test_starts_at_the_configuration_nearest_home(eight):
    _, result = eight
    assert np.abs(result.q[0] - HOME).max() < 0.01  # the first target is the home pen tip


def test_home_inside_the_margin_is_pulled_inside_by_the_barrier():
    # joint 7 at home is 0.02 rad from its limit: the pen may turn about its own axis, so
    # the solver keeps it at the margin while the posture term pulls toward home
    home = HOME.copy()
    home[6] = panda_upper(6) - 0.02
    target = figure_eight()
    target.position[:] = target.position - home_tip() + pen_poses(pen_model(PEN_LENGTH),
                                                                    home)[0][0]
    result = solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=home,
                                    joint_margin=0.05)
    assert result.q[:, 6].max() <= panda_upper(6) - 0.05
    assert result.q[:, 6].max() > panda_upper(6) - 0.1  # pressed against the barrier
    assert result.max_position_error < POSITION_TOLERANCE


def panda_upper(joint: int) -> float:
    return float(pen_model(PEN_LENGTH).upper[joint])


def test_q_start_is_kept_and_a_mismatch_is_refused(eight):
    target, first = eight
    q_start = first.q[0] + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3])  # about the pen
    result = solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME, q_start=q_start)
    np.testing.assert_array_equal(result.q[0], q_start)
    assert result.max_position_error < POSITION_TOLERANCE
    with pytest.raises(InputError, match="q_start puts the pen tip"):
        solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME,
                               q_start=first.q[0] + 0.05)


def test_is_deterministic(eight):
    target, first = eight
    again = solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME)
    assert again.q.dtype == np.float64
    np.testing.assert_array_equal(again.q, first.q)


def test_knots_are_added_where_the_spline_leaves_the_path():
    target = figure_eight()
    result = solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME, knot_rate=5.0)
    assert result.info["refinements"] >= 1 and result.info["knots"] > 4 * 5 + 1
    pos, ang = errors(result.q, target)
    assert pos.max() < POSITION_TOLERANCE and ang.max() < ORIENTATION_TOLERANCE


def test_a_long_lissajous_on_a_board():
    """A 20 s drawing at 1 kHz (24k samples): from home down to a board 19 cm lower,
    a 24 × 18 cm Lissajous, and back."""
    tip = home_tip()
    center = np.array([0.45, 0.0, 0.30])
    curve = lissajous(center, 0.12, 0.09, (3, 4))
    start = curve(np.zeros(1))[0]
    target = trajectory([(2.0, line(tip, start)), (20.0, curve), (2.0, line(start, tip))])
    result = solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME)
    pos, ang = errors(result.q, target)
    assert pos.max() < POSITION_TOLERANCE and ang.max() < ORIENTATION_TOLERANCE
    assert np.all(np.asarray(result.info["max_velocity_ratio"]) < 1.0)
    assert np.all(np.asarray(result.info["max_acceleration_ratio"]) < 1.0)
    assert result.info["min_joint_margin"] >= 0.05


def test_an_easel_facing_the_robot():
    """A vertical board (normal −x, the pen pointing away from the robot, 90° from home's
    pen axis): a 6 cm circle at 0.2 m/s. Joint-by-joint continuation from the first pose
    drives joint 6 into its limit; the barrier moves the redundancy to stay out of it."""
    normal = np.array([-1.0, 0.0, 0.0])
    center = np.array([0.6, 0.0, 0.65])

    def circle(s: np.ndarray) -> np.ndarray:
        th = 2 * np.pi * s
        return center + 0.03 * np.stack([0 * th, np.cos(th), np.sin(th)], 1)

    target = trajectory([(1.6, circle)], normal=normal)
    result = solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME)
    pos, ang = errors(result.q, target)
    assert pos.max() < POSITION_TOLERANCE and ang.max() < ORIENTATION_TOLERANCE
    assert result.info["min_joint_margin"] >= 0.05


@pytest.mark.parametrize("n", [1, 2, 3, 25])
def test_tiny_and_stationary_trajectories(n):
    tip = home_tip() - [0.0, 0.0, 0.02]
    position = np.repeat(tip[None], n, axis=0)
    position[:, 0] += np.linspace(0.0, 1e-4 * (n - 1), n)  # 0.1 mm per sample at most
    target = CartesianTrajectory(t=np.arange(n) / RATE, position=position,
                                 pen_down=np.ones(n, bool), stroke=np.zeros(n, int),
                                 normal=UP, rate=RATE)
    result = solve_joint_trajectory(target, pen_length=PEN_LENGTH, home=HOME)
    assert result.q.shape == (n, 7)
    assert result.max_position_error < POSITION_TOLERANCE
    assert result.max_orientation_error < ORIENTATION_TOLERANCE
