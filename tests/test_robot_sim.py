"""The MuJoCo execution of a joint trajectory: the scene, the impedance controller (holding,
tracking), pen/board contact, the execution metrics and the simulated drawing.

Poses are put on the board with MuJoCo's own site Jacobian (damped Gauss–Newton on the pen
tip's position and the pen axis), so these tests need neither Pinocchio nor the joint
planner."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from inkmotion.robot import panda
from inkmotion.robot.mujoco_sim import execution_metrics, reference, simulate
from inkmotion.robot.scene import Scene, build_scene
from inkmotion.robot.sim_drawing import render_sim_drawing, write_side_by_side, write_sim_drawing

HOME = np.array([0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4])
RATE = 1000.0
PAPER = (0.2, 0.15)
PEN_LENGTH = 0.2


def rotation_about_y(angle: float) -> np.ndarray:
    """Plane frame (columns u, v, normal) tilted by ``angle`` about the base y axis: the
    normal leans toward the robot (−x) as on an easel."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def make_scene(tilt: float = 0.0, height: float = 0.15) -> Scene:
    rotation = rotation_about_y(tilt)
    origin = np.array([0.45, -0.05, height]) - rotation[:, :2] @ np.array([0.05, 0.05])
    return build_scene(board_origin=origin, board_rotation=rotation, board_size=PAPER,
                       pen_length=PEN_LENGTH)


def far_scene() -> Scene:
    """A board well out of reach: no contact can disturb the arm."""
    return build_scene(board_origin=np.array([0.3, -0.1, -0.5]), board_rotation=np.eye(3),
                       board_size=PAPER, pen_length=PEN_LENGTH)


def solve_tip(scene: Scene, target: np.ndarray, q0: np.ndarray, iters: int = 60) -> np.ndarray:
    """Joint angles putting the pen tip at ``target`` with the pen along −normal."""
    model, data = scene.model, mujoco.MjData(scene.model)
    axis = -scene.normal
    jac_p, jac_r = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    q = q0.copy()
    for _ in range(iters):
        data.qpos[scene.qpos_adr] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        pen_axis = data.site_xmat[scene.pen_tip_site].reshape(3, 3)[:, 2]
        err = np.concatenate([target - data.site_xpos[scene.pen_tip_site],
                              np.cross(pen_axis, axis)])
        if np.linalg.norm(err) < 1e-10:
            break
        mujoco.mj_jacSite(model, data, jac_p, jac_r, scene.pen_tip_site)
        jac = np.vstack([jac_p, jac_r])[:, scene.dof_adr]
        q = q + jac.T @ np.linalg.solve(jac @ jac.T + 1e-8 * np.eye(6), err)
    return q


def plane_point(scene: Scene, u: float, v: float, height: float = 0.0) -> np.ndarray:
    """The point (u, v) of the plane, ``height`` m above it (negative: into the board)."""
    rotation = scene.board_rotation
    return scene.board_origin + rotation[:, 0] * u + rotation[:, 1] * v + rotation[:, 2] * height


def min_jerk(n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def line_plan(scene: Scene, depth: float = 0.0005) -> tuple[np.ndarray, ...]:
    """Hover, descend, draw a 10 cm line pressed ``depth`` m into the board, lift, at 1 kHz:
    (planned tip (N, 3), pen_down (N,), q_des (N, 7))."""
    a, b = plane_point(scene, 0.05, 0.04, -depth), plane_point(scene, 0.13, 0.10, -depth)
    lift = 0.02 * scene.normal
    segments = [(a + lift, a + lift, 200, False), (a + lift, a, 300, False),
                (a, b, 800, True), (b, b + lift, 300, False), (b + lift, b + lift, 100, False)]
    tips, down = [], []
    for p0, p1, n, is_down in segments:
        tips.append(p0 + np.outer(min_jerk(n), p1 - p0))
        down.append(np.full(n, is_down))
    planned = np.vstack(tips)
    q = solve_tip(scene, planned[0], HOME)
    q_des = []
    for p in planned:
        q = solve_tip(scene, p, q, iters=4)
        q_des.append(q)
    return planned, np.concatenate(down), np.array(q_des)


@pytest.fixture(scope="module")
def drawn_line() -> tuple:
    scene = make_scene()
    planned, pen_down, q_des = line_plan(scene)
    return scene, planned, pen_down, simulate(scene, q_des, RATE)


def test_scene_compiles_with_motors_pen_and_board():
    scene = make_scene()
    model = scene.model
    assert model.nu == 7 and model.nq == 7 and model.opt.timestep == pytest.approx(1e-3)
    assert np.allclose(model.actuator_ctrlrange[scene.actuators, 1],
                       [87, 87, 87, 87, 12, 12, 12])
    assert np.allclose(model.actuator_gear[scene.actuators, 0], 1.0)
    assert [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
            for j in scene.arm_joints] == list(panda.ARM_JOINTS)
    assert mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, scene.pen_tip_site) == "pen_tip"
    assert model.geom_type[scene.board_geom] == mujoco.mjtGeom.mjGEOM_BOX
    assert np.allclose(model.opt.gravity, [0, 0, -9.81])
    # only the pen and the board can collide
    colliding = np.flatnonzero((model.geom_contype | model.geom_conaffinity) != 0)
    assert set(colliding) == {scene.pen_geom, scene.board_geom}
    data = mujoco.MjData(model)
    data.qpos[scene.qpos_adr] = HOME
    mujoco.mj_forward(model, data)
    # the board's top face is the plane; the pen tip is pen_length along the flange's z
    half = model.geom_size[scene.board_geom]
    top = data.geom_xpos[scene.board_geom] + half[2] * scene.normal
    assert abs((top - scene.board_origin) @ scene.normal) < 1e-9
    flange_z = data.xmat[scene.flange_body].reshape(3, 3)[:, 2]
    expected_tip = data.xpos[scene.flange_body] + PEN_LENGTH * flange_z
    assert np.allclose(data.site_xpos[scene.pen_tip_site], expected_tip, atol=1e-9)
    meshes = scene.link_meshes()
    assert {"panda_link0", "panda_link7", "panda_hand"} <= set(meshes)
    assert all(path.suffix == ".stl" and path.is_file() for path in meshes.values())


def test_holding_home_for_a_second_stays_within_a_milliradian():
    sim = simulate(far_scene(), np.repeat(HOME[None], 1001, axis=0), RATE)
    drift = np.abs(sim.q - HOME).max()
    print(f"hold drift {drift:.2e} rad; {sim.wall_s / sim.duration:.4f} s wall per sim s "
          f"(real-time factor {sim.real_time_factor:.0f})")
    assert drift < 1e-3
    assert not sim.contact.any() and not sim.saturated.any()


def test_smooth_joint_trajectory_is_tracked_closely():
    t = np.arange(2001) / RATE
    wave = 0.2 * np.sin(np.pi * t / 2.0) ** 2  # 0 -> 0.2 rad -> back near 0, at rest at t=0
    q_des = HOME + np.outer(wave, [1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0])
    sim = simulate(far_scene(), q_des, RATE)
    error = np.abs(sim.q - q_des).max(axis=0)
    print("joint tracking error (rad):", np.array2string(error, precision=6))
    assert error.max() < 2e-3
    # without the inertia feed-forward the same gains lag an order of magnitude more
    lagging = simulate(far_scene(), q_des, RATE, feedforward=False)
    assert np.abs(lagging.q - q_des).max() > 5 * error.max()


def test_reference_resamples_a_slower_rate_onto_the_simulation_steps():
    t = np.arange(101) / 100.0
    q_des = HOME + np.outer(np.sin(t), np.ones(7))
    times, q, qd, qdd = reference(q_des, 100.0, 1e-3)
    assert len(times) == 1001 and np.allclose(q[::10], q_des, atol=1e-12)
    assert np.allclose(qd[:, 0], np.cos(times), atol=1e-5)
    assert np.allclose(qdd[50:-50, 0], -np.sin(times[50:-50]), atol=1e-3)


@pytest.mark.parametrize("tilt", [0.0, np.radians(30.0)])
def test_pen_pressed_into_the_board_touches_it_on_the_plane(tilt):
    scene = make_scene(tilt)
    target = plane_point(scene, 0.1, 0.075, -0.001)  # 1 mm into the board
    q = solve_tip(scene, target, HOME)
    sim = simulate(scene, np.repeat(q[None], 501, axis=0), RATE)
    settled = slice(100, None)
    assert sim.contact[settled].all() and sim.penetrating[settled].any()
    assert sim.contact_force[settled].mean() > 0.2  # N, the impedance presses the pen
    points = sim.contact_points
    assert np.abs((points - scene.board_origin) @ scene.normal).max() < 1e-9  # on the plane
    assert (sim.pen_gap[settled] < scene.touch_tolerance).all()  # touching
    assert np.median(sim.pen_gap[settled]) < 0  # mostly pressed in, by less than 1 mm
    assert (sim.pen_gap[settled] > -0.001).all()
    on_plane = target + 0.001 * scene.normal
    assert np.linalg.norm(points[-1] - on_plane) < 3e-3


def test_drawn_line_is_inked_and_measured(drawn_line):
    scene, planned, pen_down, sim = drawn_line
    metrics = execution_metrics(sim, planned, pen_down)
    print({k: round(metrics[k], 3) for k in (
        "contact_coverage", "tracking_down_plane_rms_mm", "tracking_down_plane_max_mm",
        "tracking_down_normal_mean_mm", "tracking_up_3d_max_mm", "contact_force_mean_n",
        "real_time_factor")})
    assert metrics["contact_coverage"] > 0.95
    assert metrics["tracking_down_plane_max_mm"] < 2.0
    assert metrics["tracking_up_3d_max_mm"] < 3.0
    assert metrics["control_down_plane_rms_mm"] == pytest.approx(
        metrics["tracking_down_plane_rms_mm"], abs=0.05)  # the IK here is exact
    assert metrics["commanded_joint_velocity_min_margin"] > 0.5
    assert metrics["executed_flange_speed_ratio"] < 1.0
    assert metrics["real_time_factor"] > 1.0
    assert 0.0 <= metrics["spurious_contact"] < 0.1
    # the line's contact points lie on the plane along the planned segment
    strokes = sim.contact_strokes()
    assert len(strokes) >= 1
    longest = max(strokes, key=len)
    assert np.linalg.norm(longest[-1] - longest[0]) > 0.09
    # link poses for a replay: 50 Hz, one column per mesh
    assert sim.pose_pos.shape == (len(sim.pose_t), len(sim.link_names), 3)
    assert np.allclose(np.linalg.norm(sim.pose_quat, axis=-1), 1.0)
    assert set(sim.link_poses(0)) == set(sim.link_meshes())
    assert np.diff(sim.pose_t)[0] == pytest.approx(0.02)


def test_sim_drawing_has_ink_where_the_pen_touched(drawn_line, tmp_path):
    scene, planned, pen_down, sim = drawn_line
    canvas = (400, 300)  # px, 2000 px per metre on the 0.2 × 0.15 m paper
    path = write_sim_drawing(tmp_path / "sim_drawing.png", sim.contact_strokes(),
                             scene.board_origin, scene.board_rotation, scene.paper, canvas)
    image = read_gray(path)
    assert image.shape == (300, 400)
    ink = image < 128
    # the line runs from (0.05, 0.04) m to (0.13, 0.10) m: px (100, 80) -> (260, 200)
    for s in np.linspace(0.1, 0.9, 9):
        x, y = np.round(np.array([100, 80]) + s * np.array([160, 120])).astype(int)
        assert ink[y - 3:y + 4, x - 3:x + 4].any(), (x, y)
    assert not ink[:, :80].any() and not ink[:, 290:].any()  # nothing beyond the ends
    side = write_side_by_side(tmp_path / "side.png", path, path)
    assert read_gray(side).shape[1] == 2 * 400 + 8


def test_sim_drawing_uses_the_given_mapping_and_splits_at_gaps():
    points = np.array([[0.01, 0.01, 0.0], [0.02, 0.01, 0.0],  # one short line
                       [0.08, 0.05, 0.0], [0.09, 0.05, 0.0]])  # a pen lift, then another

    def flip(uv: np.ndarray) -> np.ndarray:  # v up on the paper, y down on the canvas
        return np.column_stack([uv[:, 0] * 1000.0, 100.0 - uv[:, 1] * 1000.0])

    image = render_sim_drawing(points, np.zeros(3), np.eye(3), (0.1, 0.1), (100, 100),
                               mapping=flip, width_px=2, max_gap=0.02)
    ink = image < 128
    assert ink[90, 15] and ink[50, 85]
    assert not ink[70, 50]  # no line across the lift
    assert not render_sim_drawing(np.empty((0, 3)), np.zeros(3), np.eye(3), (0.1, 0.1),
                                  (100, 100)).min() < 255


def read_gray(path) -> np.ndarray:
    import cv2

    return cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
