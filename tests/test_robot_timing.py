"""Robot setup file, drawing-plane calibration and timing of a drawing to v_max / a_max.

Limits are checked by finite differences of the resampled positions at the control rate:
the first difference is the mean velocity over a period and the second the hat-weighted
mean acceleration over two, so neither can exceed the continuous peak. The timing keeps
the continuous peaks at 0.999 of the limits; the tests allow 0.1 % (``TOL``) for rounding.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from inkmotion.errors import InputError
from inkmotion.robot.calibration import ROBOT_SIDE, DrawingPlane, PaperMapping
from inkmotion.robot.setup import (
    DEFAULT_SETUP,
    RobotSetup,
    load_setup,
    parse_setup,
    setup_to_toml,
)
from inkmotion.robot.timing import rest_to_rest, time_drawing
from inkmotion.sigma_lognormal import Drawing, MotorPlan

DATA = Path(__file__).parent / "data"
TOL = 1e-3


# --- calibration ------------------------------------------------------------------------

def _random_frame(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A random origin and rotation whose normal faces ROBOT_SIDE (as calibration orients)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    rotation = q * np.sign(np.diag(r))
    if np.linalg.det(rotation) < 0:
        rotation[:, 2] *= -1
    origin = rng.uniform([0.2, -0.4, -0.1], [0.6, 0.4, 0.5])
    if (ROBOT_SIDE - origin) @ rotation[:, 2] < 0:
        rotation = rotation @ np.diag([1.0, -1.0, -1.0])
    return origin, rotation


def _corners(origin: np.ndarray, rotation: np.ndarray, w: float = 0.297,
             h: float = 0.21) -> np.ndarray:
    uv = np.array([[0, 0, 0], [w, 0, 0], [w, h, 0], [0, h, 0]], dtype=float)
    return origin + uv @ rotation.T


@pytest.mark.parametrize("seed", range(8))
def test_calibration_recovers_a_noisy_plane(seed):
    rng = np.random.default_rng(seed)
    origin, rotation = _random_frame(rng)
    points = _corners(origin, rotation) + rng.normal(scale=3e-4, size=(4, 3))
    plane = DrawingPlane.from_points(points)
    angle = np.degrees(np.arccos(np.clip(plane.normal @ rotation[:, 2], -1, 1)))
    assert angle < 0.5
    assert np.linalg.norm(plane.origin - origin) < 1e-3
    assert np.degrees(np.arccos(plane.rotation[:, 0] @ rotation[:, 0])) < 0.5
    assert np.allclose(plane.rotation.T @ plane.rotation, np.eye(3), atol=1e-12)
    assert np.linalg.det(plane.rotation) > 0
    assert plane.residual < 1e-3
    assert plane.size == pytest.approx((0.297, 0.21), abs=1e-3)
    uv, height = plane.to_plane(plane.to_base(np.array([[0.1, 0.05]]), 0.02))
    assert np.allclose(uv, [[0.1, 0.05]]) and np.allclose(height, 0.02)


def test_calibration_clockwise_corners_keep_the_paper_in_the_positive_quadrant():
    origin, rotation = np.array([0.4, -0.1, 0.0]), np.eye(3)
    p = _corners(origin, rotation)
    plane = DrawingPlane.from_points(p[[3, 2, 1, 0]])  # clockwise seen from above
    assert np.allclose(plane.normal, [0, 0, 1])
    assert np.allclose(plane.rotation, np.eye(3), atol=1e-12)
    assert np.allclose(plane.origin, origin)


def test_calibration_normal_faces_the_robot():
    for z, normal in ((0.0, [0, 0, 1]), (0.34, [0, 0, 1]), (-0.2, [0, 0, 1])):
        p = _corners(np.array([0.3, -0.15, z]), np.eye(3))
        assert np.allclose(DrawingPlane.from_points(p).normal, normal)
    wall = np.array([[0.6, -0.15, 0.2], [0.6, 0.15, 0.2], [0.6, 0.15, 0.4], [0.6, -0.15, 0.4]])
    assert np.allclose(DrawingPlane.from_points(wall).normal, [-1, 0, 0])


def test_calibration_refuses_non_planar_points_naming_the_residual():
    p = _corners(np.array([0.3, -0.15, 0.0]), np.eye(3))
    p[:, 2] += np.array([1, -1, 1, -1]) * 3e-3
    with pytest.raises(InputError, match=r"3\.00 mm .*tolerance 2\.00 mm"):
        DrawingPlane.from_points(p, source="bench.toml")
    assert DrawingPlane.from_points(p, tolerance=0.004).residual == pytest.approx(3e-3)


@pytest.mark.parametrize("case, match", [
    ("collinear", "collinear or out of order"),
    ("crossed", "collinear or out of order"),
    ("short side", "shorter than 50 mm"),
    ("coincident", "shorter than 50 mm"),
    ("nan", "four finite corner points"),
    ("three points", "four finite corner points"),
])
def test_calibration_refuses_degenerate_points(case, match):
    p = _corners(np.array([0.3, -0.15, 0.0]), np.eye(3))
    points = {
        "collinear": np.array([[0.3, 0, 0], [0.4, 0, 0], [0.5, 0, 0], [0.6, 0, 0]]),
        "crossed": p[[0, 2, 1, 3]],
        "short side": np.array([p[0], p[0] + [0.01, 0, 0], p[2], p[3]]),
        "coincident": np.array([p[0], p[0], p[2], p[3]]),
        "nan": np.where(np.eye(4, 3, dtype=bool), np.nan, p),
        "three points": p[:3],
    }[case]
    with pytest.raises(InputError, match=match) as err:
        DrawingPlane.from_points(points, source="bench.toml")
    assert str(err.value).startswith("bench.toml: ")


def test_paper_mapping_fits_centres_and_does_not_mirror():
    m = PaperMapping.from_canvas((350.0, 250.0), (0.297, 0.21), 0.01)
    assert m.scale == pytest.approx(min(0.277 / 350, 0.19 / 250))
    corners = m.px_to_plane(np.array([[0, 0], [350, 250]]))
    # centred: the drawn box is symmetric on the paper
    assert corners[0, 0] + corners[1, 0] == pytest.approx(0.297)
    assert corners[0, 1] + corners[1, 1] == pytest.approx(0.21)
    assert corners.min() >= 0.01 - 1e-12 and corners[:, 0].max() <= 0.287 + 1e-12
    # image right -> +u, image down -> −v: a y-down image seen from the normal side
    right, down = m.px_to_plane(np.array([[1, 0], [0, 1]])) - m.px_to_plane(np.zeros((1, 2)))
    assert right[0] > 0 and right[1] == 0 and down[1] < 0 and down[0] == 0
    xy = np.array([[12.5, 200.0], [349.0, 0.5]])
    assert np.allclose(m.plane_to_px(m.px_to_plane(xy)), xy)


# --- setup file -------------------------------------------------------------------------

def test_default_setup_loads_and_round_trips(tmp_path):
    setup = load_setup()
    assert isinstance(setup, RobotSetup)
    assert setup.v_max == 0.25 and setup.control_rate == 1000.0
    assert setup.source == DEFAULT_SETUP.read_text()
    assert np.allclose(setup.plane.normal, [0, 0, 1])
    path = tmp_path / "setup.toml"
    path.write_text(setup_to_toml(setup))
    again = load_setup(path)
    for name in RobotSetup.__dataclass_fields__:
        if name in ("plane", "source"):
            continue
        assert np.array_equal(getattr(again, name), getattr(setup, name)), name
    assert np.allclose(again.plane.rotation, setup.plane.rotation)
    assert setup_to_toml(again) == setup_to_toml(setup)


def test_default_setup_documents_every_key():
    lines = DEFAULT_SETUP.read_text().splitlines()
    keys = [i for i, line in enumerate(lines) if "=" in line and not line.startswith(("#", " "))]
    assert len(keys) == 15
    for i in keys:
        assert lines[i - 1].startswith("#"), lines[i]


def test_default_plane_is_reachable_with_the_pen_down():
    from inkmotion.robot.kinematics import check_reachable, pen_model, pen_poses

    setup = load_setup()
    w, h = setup.paper
    grid = np.array([[u, v] for u in np.linspace(0, w, 5) for v in np.linspace(0, h, 5)])
    for height in (setup.pen_distance(20.0), setup.pen_up, setup.pen_up + 0.05):
        check_reachable(setup.plane.to_base(grid, height), setup.plane.normal,
                        setup.pen_length, joint_margin=setup.joint_margin)
    # the home pose holds the pen 0.1 m above the paper's middle, pointing down
    tip, axis = pen_poses(pen_model(setup.pen_length), setup.home[None])
    uv, height = setup.plane.to_plane(tip)
    assert uv[0] == pytest.approx([w / 2, h / 2], abs=0.01)
    assert height[0] == pytest.approx(0.1, abs=0.005)
    assert axis[0] @ setup.plane.normal < -0.999


def test_overrides_replace_values_and_are_recorded():
    home = np.array([0.1, -0.7, 0.0, -2.3, 0.0, 1.6, 0.8])
    setup = load_setup(overrides={"v_max": 0.1, "paper": (0.2, 0.15), "limits.a_max": 1.0,
                                  "home": home})
    assert setup.v_max == 0.1 and setup.a_max == 1.0 and setup.paper == (0.2, 0.15)
    assert np.array_equal(setup.home, home)
    assert "with overrides: v_max = 0.1" in setup.source.splitlines()[0]
    assert parse_setup(setup.source).v_max == 0.1


def _edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


@pytest.mark.parametrize("edit, key, says", [
    (lambda t: _edit(t, "v_max = 0.25", "v_maxx = 0.25"), "[limits] v_maxx", "unknown key"),
    (lambda t: _edit(t, "v_max = 0.25\n", ""), "[limits] v_max", "is missing"),
    (lambda t: _edit(t, "v_max = 0.25", 'v_max = "fast"'), "[limits] v_max", "a number > 0"),
    (lambda t: _edit(t, "v_max = 0.25", "v_max = nan"), "[limits] v_max", "a number > 0"),
    (lambda t: _edit(t, "v_max = 0.25", "v_max = -1"), "[limits] v_max", "a number > 0"),
    (lambda t: _edit(t, "a_max = 2.5", "a_max = true"), "[limits] a_max", "a number > 0"),
    (lambda t: _edit(t, "limit_fraction = 0.9", "limit_fraction = 1.5"),
     "[limits] limit_fraction", "in (0, 1]"),
    (lambda t: _edit(t, "home = [0.0, ", "home = ["), "[robot] home", "an array of 7"),
    (lambda t: _edit(t, "home = [0.0, ", 'home = ["0", '), "[robot] home", "an array of 7"),
    (lambda t: _edit(t, "[0.415, -0.1485, 0.34],\n", "[0.415, -0.1485],\n"),
     "[plane] points", "an array of 4 × 3"),
    (lambda t: _edit(t, "[0.205, -0.1485, 0.34]", "[0.205, -0.1485, 0.37]"),
     "[plane] points", "not coplanar"),
    (lambda t: _edit(t, "margin = 0.01", "margin = 0.2"), "[paper] margin", "leaves no paper"),
    (lambda t: _edit(t, "width = 0.297", "width = 0.5"), "[paper] width", "exceeds"),
    (lambda t: _edit(t, "up = 0.03", "up = -0.002"), "[pen] up", "a number > 0"),
    (lambda t: _edit(t, "[robot]", "[robots]"), "robots", "unknown key [robots]"),
    (lambda t: t + "\nspeed = 1\n", "[robot] speed", "unknown key"),
    (lambda t: _edit(t, "[pen]", "[pen"), "", "is not valid TOML"),
])
def test_setup_errors_name_the_file_and_key_in_one_sentence(tmp_path, edit, key, says):
    path = tmp_path / "bench.toml"
    path.write_text(edit(DEFAULT_SETUP.read_text()))
    with pytest.raises(InputError) as err:
        load_setup(path)
    message = str(err.value)
    assert message.startswith(f"{path}: "), message
    assert key in message and says in message, message
    assert message.endswith(".") and ". " not in message.replace(str(path), ""), message


def test_setup_override_errors():
    with pytest.raises(InputError, match="unknown setup override 'speed'"):
        load_setup(overrides={"speed": 1.0})
    with pytest.raises(InputError, match=r"the setup overrides: \[limits\] v_max must be"):
        load_setup(overrides={"v_max": float("nan")})
    with pytest.raises(InputError, match="missing file|cannot read"):
        load_setup("/nonexistent/bench.toml")


# --- timing -----------------------------------------------------------------------------

def _finite_differences(c) -> tuple[np.ndarray, np.ndarray]:
    dt = 1.0 / c.rate
    speed = np.linalg.norm(np.diff(c.position, axis=0), axis=1) / dt
    acc = np.linalg.norm(np.diff(c.position, 2, axis=0), axis=1) / dt**2
    return speed, acc


def _check_program(c, setup: RobotSetup, start: np.ndarray | None = None) -> None:
    """Finite, uniformly sampled, within the limits, at rest at both ends, pen flags
    consistent, transfers at pen_up height."""
    n = len(c.t)
    assert c.position.shape == (n, 3) and c.pen_down.shape == (n,) and c.stroke.shape == (n,)
    assert np.all(np.isfinite(c.position)) and np.isfinite(c.time_scale) and c.time_scale > 0
    assert np.array_equal(c.t, np.arange(n) / c.rate)
    assert np.array_equal(c.pen_down, c.stroke >= 0)
    speed, acc = _finite_differences(c)
    assert speed.max() <= setup.v_max * (1 + TOL), speed.max()
    assert acc.max() <= setup.a_max * (1 + TOL), acc.max()
    assert speed[0] < 1e-3 and speed[-1] < 1e-3  # rest-to-rest quintic ends
    assert np.array_equal(c.position[0], c.position[-1])
    if start is not None:
        assert np.allclose(c.position[0], start)
    assert not c.pen_down[0] and not c.pen_down[-1]
    uv, height = setup.plane.to_plane(c.position)
    assert np.all(height >= setup.pen_distance(1e3) - 1e-12)  # never below the paper's reach
    # the pen is up only between strokes: away from every stroke end, it flies at pen_up
    ends = np.array([uv[c.stroke == i][[0, -1]] for i in np.unique(c.stroke[c.pen_down])])
    first, last = np.flatnonzero(c.pen_down)[[0, -1]]
    between = ~c.pen_down & (np.arange(n) > first) & (np.arange(n) < last)
    far = np.min(np.linalg.norm(uv[:, None, None] - ends[None], axis=-1), axis=(1, 2)) > 1e-6
    assert np.allclose(height[between & far], setup.pen_up, atol=1e-12)
    info = c.info
    assert info["total_s"] == pytest.approx((n - 1) / c.rate)
    assert info["drawing_s"] + info["transfer_s"] == pytest.approx(info["total_s"])
    assert info["time_scale"] == c.time_scale
    assert all(np.isfinite(v) for v in info.values() if isinstance(v, float))


def test_timed_tag_is_within_and_at_the_limits():
    setup = load_setup()
    drawing = Drawing.load(DATA / "v1_job" / "plan.json")
    start = setup.plane.to_base(np.array([[0.15, 0.1]]), 0.1)[0]
    c = time_drawing(drawing, setup, start=start)
    _check_program(c, setup, start)
    speed, acc = _finite_differences(c)
    drawing_speed = speed[c.pen_down[1:] & c.pen_down[:-1]]
    drawing_acc = acc[c.pen_down[2:] & c.pen_down[1:-1] & c.pen_down[:-2]]
    # tight: one limit is reached within 2 % while drawing
    assert max(drawing_speed.max() / setup.v_max, drawing_acc.max() / setup.a_max) > 0.98
    assert c.info["limiting"] in ("speed", "acceleration")
    assert c.info["strokes"] == 3 and set(np.unique(c.stroke)) == {-1, 0, 1, 2}
    # each stroke is drawn in order, once, at the mapped plan positions, pen down
    mapping = PaperMapping.from_canvas(drawing.canvas, setup.paper, setup.margin)
    for i, plan in enumerate(drawing.plans):
        idx = np.flatnonzero(c.stroke == i)
        assert np.all(np.diff(idx) == 1)
        uv, height = setup.plane.to_plane(c.position[idx])
        start_px = plan.points[0, :2].double().numpy()[None]
        assert np.allclose(uv[0], mapping.px_to_plane(start_px)[0], atol=1e-6)
        assert np.allclose(height, setup.pen_distance(plan.width / 2))
    assert c.info["scale_m_per_px"] == pytest.approx(mapping.scale)
    assert c.info["outside_paper_m"] == 0.0


def test_time_scale_follows_the_limit():
    drawing = Drawing.load(DATA / "v1_job" / "plan.json")
    slow = time_drawing(drawing, load_setup(overrides={"v_max": 0.05, "a_max": 13.0}))
    fast = time_drawing(drawing, load_setup(overrides={"v_max": 0.1, "a_max": 13.0}))
    assert slow.info["limiting"] == fast.info["limiting"] == "speed"
    assert slow.time_scale == pytest.approx(2 * fast.time_scale, rel=1e-6)
    assert slow.info["drawing_peak_speed"] == pytest.approx(0.05 * 0.999)
    by_acc = time_drawing(drawing, load_setup(overrides={"v_max": 1.7, "a_max": 0.5}))
    assert by_acc.info["limiting"] == "acceleration"
    assert by_acc.info["drawing_peak_acc"] == pytest.approx(0.5 * 0.999)


def test_rest_to_rest_move_meets_its_peaks():
    a, b = np.zeros(3), np.array([0.1, 0.05, 0.0])
    for v_max, a_max in ((0.25, 100.0), (100.0, 2.5)):
        p = rest_to_rest(a, b, v_max, a_max, 1000.0)
        speed = np.linalg.norm(np.diff(p, axis=0), axis=1) * 1000
        acc = np.linalg.norm(np.diff(p, 2, axis=0), axis=1) * 1e6
        assert np.array_equal(p[0], a) and np.array_equal(p[-1], b)
        assert speed.max() <= v_max and acc.max() <= a_max
        assert max(speed.max() / v_max, acc.max() / a_max) > 0.99
    assert rest_to_rest(a, a, 0.25, 2.5, 1000.0).shape == (1, 3)


def _plan(points: list, **kw: float) -> MotorPlan:
    return MotorPlan.from_points(points, dtype=torch.float64, **kw)


# toppra-style robustness table: every degenerate drawing must time to a finite program
# within the limits that starts and ends at rest
ROBUSTNESS = {
    "zero-length stroke": [_plan([[100, 100], [100, 100]]), _plan([[10, 10], [200, 150]])],
    "only a dot": [_plan([[100, 100], [100, 100], [100, 100]])],
    "one sub-movement": [_plan([[10, 20], [300, 200]])],
    "same point twice": [_plan([[50, 50], [150, 80]]), _plan([[150, 80], [50, 50]])],
    "two dots at one point": [_plan([[60, 60], [60, 60]]), _plan([[60, 60], [60, 60]])],
    "tiny drawing": [_plan([[100, 100], [100.001, 100.0005], [100.0, 100.001]])],
    "huge T_end": [_plan([[10, 10], [300, 100], [20, 200]], T=500.0)],
    "fast plan": [_plan([[10, 10], [300, 100], [20, 200]], T=0.01)],
    "skewed arcs, overlapping": [_plan([[10, 10], [200, 50], [100, 200], [300, 220]],
                                       ac=0.5, delta=1.5, delta_t=0.1)],
    "2.5D pressure": [_plan([[10, 10, 0.0], [200, 50, 8.0], [100, 200, 1.0]])],
    "2.5D press in place": [_plan([[100, 100, 0.0], [100, 100, 10.0], [100, 100, 0.0]])],
}


@pytest.mark.parametrize("case", ROBUSTNESS)
def test_degenerate_drawings_time_safely(case):
    setup = load_setup()
    c = time_drawing(Drawing((350.0, 250.0), ROBUSTNESS[case]), setup)
    _check_program(c, setup)
    assert c.info["strokes"] == len(ROBUSTNESS[case])
    assert np.count_nonzero(c.pen_down) >= 2 * len(ROBUSTNESS[case])
    assert c.info["total_s"] < 60.0


@pytest.mark.parametrize("tilt_deg", [0.3, 1.0, 20.0])
def test_a_tilted_board_is_drawn_as_fast_as_a_level_one(tilt_deg):
    """A taught plane is never exactly level. The pen left home pointing straight down and
    the joint solver was asked for the plane's tilt one control period later: a 0.3° tilt
    made the first step 74× the acceleration limit, and the retiming slowed the whole
    drawing five-fold (1°: ten-fold); 5° and more were refused. The first move now turns
    the pen (and the last turns it back): the program takes as long as on the level board,
    nothing is retimed, and the pen is along the plane's normal wherever it draws."""
    from inkmotion.robot.program import plan_program

    drawing = Drawing.load(DATA / "v4_jobs" / "fit" / "plan.json")
    level = load_setup(None)
    theta = np.radians(tilt_deg)
    centre = level.plane_points.mean(axis=0)
    turn = np.array([[np.cos(theta), 0.0, np.sin(theta)], [0.0, 1.0, 0.0],
                     [-np.sin(theta), 0.0, np.cos(theta)]])  # about y, through the centre
    tilted = load_setup(None, overrides={
        "plane_points": ((level.plane_points - centre) @ turn.T + centre).tolist()})
    flat = plan_program(drawing, level)
    steep = plan_program(drawing, tilted)
    assert not steep.info["limits"]["retimed"]
    assert steep.joints.t[-1] == pytest.approx(flat.joints.t[-1], rel=0.02)
    down = steep.cartesian.pen_down
    axes = steep.cartesian.pen_normals()
    assert np.allclose(axes[down], tilted.plane.normal, atol=1e-9)
    assert steep.joints.max_orientation_error < np.radians(2.0)
    assert steep.cartesian.info["total_s"] == pytest.approx(steep.joints.t[-1], abs=2e-3)


def test_a_home_outside_the_joint_ranges_names_its_key():
    """Seven zeros (joint 4's range is −3.07 to −0.07 rad) said "q_start lies within
    joint_margin of a joint limit; move the robot away from its limits"."""
    text = DEFAULT_SETUP.read_text().replace(
        "home = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]", "home = [0, 0, 0, 0, 0, 0, 0]")
    with pytest.raises(InputError, match=r"bench.toml: \[robot\] home joint 4 = 0 rad is "
                                         r"outside the Franka arms' range"):
        parse_setup(text, "bench.toml")


def test_a_board_above_the_home_pen_tip_is_refused():
    """A board 5 cm above home's pen tip: the move to the first stroke went through it; the
    drawing ran to "done" with a slash through the letters, 69 N and 10 mm off the plan."""
    from inkmotion.robot.program import plan_program

    level = load_setup(None)
    high = load_setup(None, overrides={"plane_points": (level.plane_points
                                                         + [0.0, 0.0, 0.15]).tolist()})
    drawing = Drawing.load(DATA / "v4_jobs" / "fit" / "plan.json")
    with pytest.raises(InputError, match=r"The home pose's pen tip is 50 mm below the board "
                                         r"\(\[plane\] points\), so the move to the first "
                                         r"stroke would pass through it"):
        plan_program(drawing, high)


def test_a_home_outside_the_simulated_arm_s_range_names_the_joint():
    """A home the FR3 allows (joint 6 at 3.9 rad) but the Panda does not said "q_start lies
    within joint_margin of a joint limit; move the robot away from its limits"."""
    from inkmotion.robot.program import plan_program

    home = load_setup(None).home.copy()
    home[5] = 3.9
    setup = load_setup(None, overrides={"home": home})
    drawing = Drawing.load(DATA / "v4_jobs" / "fit" / "plan.json")
    with pytest.raises(InputError, match=r"\[robot\] home, or the arm's own\) has joint 6 at "
                                         r"3\.9000 rad, outside this arm's range"):
        plan_program(drawing, setup)
