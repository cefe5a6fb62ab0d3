"""Timing a drawing for the robot (paper, "Executing ΣΛ trajectories with a robot": "we then
resample the trajectories using a time step that ensures predefined speed and acceleration
limits v_max and a_max").

Strokes. Each plan path x(t) (px, plan seconds) is mapped onto the paper (u, v) = M(x) with
one scale s (m/px), and its radius r (3rd coordinate, or width / 2 for a 2-D plan) onto the
pen's distance from the paper d(r) = contact_offset − press_per_px·r, so the pen tip moves
as y(t) = (u, v, d) in the plane frame. Uniform time scaling t_robot = k·t_plan divides the
speed by k and the acceleration by k², so the smallest k that keeps the whole drawing within
the limits is

    k = max(max|ẏ| / v_max, sqrt(max|ÿ| / a_max)),

one k for all strokes: the drawing keeps the plan's relative timing (the rhythm of the
gesture, the speed ratios a spray renderer turns into ink), at the cost of strokes slower
than their own limit allows. The peaks are measured on a grid uniform in each
sub-movement's own ln τ (z ∈ [−5, 5] in steps of 0.025 σ, the lognormal's natural scale,
relative peak error < 2·10⁻⁴), then the limits are used at ``SAFETY`` = 0.999 of their
value; the exact kinematics at the control samples are checked and k is raised if a sample
still exceeds a limit. Each stroke is then resampled at the control rate by evaluating the
exact kinematics at t_plan = t_a + j / (rate·k): no interpolation error.

Rest. A lognormal's ±3σ window (the plan's [0, T_end]) starts and ends at about 1 % of its
peak speed, not at rest. The stroke is evaluated over the lognormals' whole evaluated
support instead, t ∈ [t_a, t_b] with t_a = min_i t0_i + e^{μ_i−5σ_i} and t_b = max_i t0_i +
e^{μ_i+5σ_i} (the kinematics neglect Φ(−5) ≈ 3·10⁻⁷ of each displacement beyond it), where
the pen is at p0 and p_m with a speed below 2·10⁻⁵ of the peak. The price is time: with
the fitting's Ac = 0.01 (σ = 0.1, T = 0.8 s) each stroke gains about 0.18 s before its
first window and 0.39 s after its last (plan time), where the pen creeps over the last
0.14 % of its displacements. A drawing that does not move at all (dots only) keeps its
plan timing, at most ``MAX_DOT_S`` per dot, and reports ``limiting = "none"``.

Transfers. Between strokes the pen lifts along the normal to ``pen_up``, moves in a straight
line above the next stroke's start, lowers to ``TOUCH_GAP`` above the paper and lands at
``TOUCH_SPEED`` at most; the program starts and ends at
``start``. Each of these moves is a minimum-jerk (quintic) rest-to-rest profile
s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, whose peaks are |ṡ| = 15/8 at τ = ½ and |s̈| = 10/√3 at
τ = (3 − √3)/6, so a move of length L lasts T = max(15/8·L/v_max, sqrt(10/√3·L/a_max)),
rounded up to a whole number of control periods.

Turning. The pen points along the plane's −normal while it draws, but at ``start`` (the
home pose) it points where home holds it: straight down, not along a taught plane's
normal, which is never exactly vertical. The first move (start → above the first stroke)
therefore turns the pen from home's axis to the plane's, and the last move turns it back,
each with the move's own profile s(τ): n(s) = slerp(n_home, n_plane, s), the move lasting
long enough for both the distance and the angle (an angle θ counts as ``TURN_RADIUS``·θ of
distance). Without it the joint solver was asked for the plane's tilt one control period
after home: a step that a 0.3° tilt made 74× the arm's acceleration limit, which the
retiming then paid for by slowing the whole drawing five-fold.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from inkmotion.robot.calibration import PaperMapping
from inkmotion.robot.setup import RobotSetup
from inkmotion.robot.types import CartesianTrajectory
from inkmotion.sigma_lognormal.kinematics import kinematics
from inkmotion.sigma_lognormal.plan import Drawing
from inkmotion.sigma_lognormal.support import Support, support

#: fraction of v_max and a_max the drawing's measured peaks are scaled to (covers the
#: peak between grid points, < 2e-4 relative)
SAFETY = 0.999
#: minimum-jerk peak factors: |ṡ| ≤ 15/8, |s̈| ≤ 10/√3 for s(τ) = 10τ³ − 15τ⁴ + 6τ⁵
QUINTIC_SPEED = 15.0 / 8.0
QUINTIC_ACCELERATION = 10.0 / math.sqrt(3.0)
#: the pen lowers fast to TOUCH_GAP (m) above the paper, then lands at most at TOUCH_SPEED
#: (m/s): landing at transfer speed jolts the arm (measured in MuJoCo on 49867.json: joint 2
#: at 1.45× its acceleration limit for a few ms at each landing)
TOUCH_GAP = 0.002
TOUCH_SPEED = 0.02
#: a drawing that does not move (dots only) keeps its plan timing, at most this long per dot
MAX_DOT_S = 1.0
#: the default start: this far (m) above the pen-up height over the first stroke's start
START_CLEARANCE = 0.05
#: a turn of the pen by θ rad takes as long as a move of TURN_RADIUS·θ m (a point this far
#: from the tip along the pen moves that much): 1 rad at v_max = 0.25 m/s in about 0.8 s
TURN_RADIUS = 0.1
#: pen axes closer than this (rad) are one axis: no turn (round-off of a level plane)
SAME_AXIS = 1e-9


def _tip(stroke: Support, t: np.ndarray, mapping: PaperMapping, setup: RobotSetup
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pen tip (u, v, d) in the plane frame at plan times ``t`` (n,): positions (n, 3) m,
    velocities (n, 3) m/s and accelerations (n, 3) m/s² in plan time."""
    plan = stroke.plan
    with torch.no_grad():
        kin = kinematics(plan, torch.as_tensor(t, dtype=torch.float64))
    x, v, a = (k.numpy() for k in kin)
    if plan.dim == 3:
        r, vr, ar = x[:, 2], v[:, 2], a[:, 2]
    else:
        r, vr, ar = np.full(len(t), plan.width / 2.0), np.zeros(len(t)), np.zeros(len(t))
    position = np.column_stack((mapping.px_to_plane(x[:, :2]), setup.pen_distance(r)))
    velocity = np.column_stack((mapping.velocity_to_plane(v[:, :2]), -setup.press_per_px * vr))
    acceleration = np.column_stack((mapping.velocity_to_plane(a[:, :2]),
                                    -setup.press_per_px * ar))
    return position, velocity, acceleration


def _peaks(velocity: np.ndarray, acceleration: np.ndarray) -> tuple[float, float]:
    """max |v| and max |a| over samples (n, 3) (0 for none)."""
    speed = float(np.linalg.norm(velocity, axis=1).max(initial=0.0))
    return speed, float(np.linalg.norm(acceleration, axis=1).max(initial=0.0))


def time_scale(peak_speed: float, peak_acc: float, v_max: float, a_max: float
               ) -> tuple[float, str]:
    """k = max(peak_speed / v_max, sqrt(peak_acc / a_max)) and which limit sets it
    ("speed", "acceleration", or "none" when nothing moves: k = 0)."""
    by_speed = peak_speed / v_max
    by_acc = math.sqrt(peak_acc / a_max)
    if by_speed == 0.0 and by_acc == 0.0:
        return 0.0, "none"
    return (by_speed, "speed") if by_speed >= by_acc else (by_acc, "acceleration")


def _sample(stroke: Support, k: float, rate: float, mapping: PaperMapping,
            setup: RobotSetup) -> tuple[np.ndarray, float, float]:
    """The stroke at the control rate under time scale ``k``: positions (n + 1, 3) m in the
    plane frame at t_plan = t_a + j/(rate·k), clamped to t_b (the pen rests there), with
    n = ⌈k·(t_b − t_a)·rate⌉ ≥ 1; and the exact peak speed and acceleration of these
    samples in robot time."""
    n = max(1, math.ceil(k * (stroke.t_b - stroke.t_a) * rate - 1e-9))
    t = np.minimum(stroke.t_a + np.arange(n + 1) / (rate * k), stroke.t_b)
    position, velocity, acceleration = _tip(stroke, t, mapping, setup)
    speed, acc = _peaks(velocity, acceleration)
    return position, speed / k, acc / k**2


def _quintic(length: float, v_max: float, a_max: float, rate: float) -> np.ndarray:
    """The minimum-jerk profile s(τ) (n + 1,) of a rest-to-rest move of ``length`` at the
    control ``rate``: n = ⌈T·rate⌉, T = max(15/8·L/v_max, sqrt(10/√3·L/a_max)), so its speed
    stays ≤ v_max and its acceleration ≤ a_max; (1,) zero when nothing moves."""
    duration = max(QUINTIC_SPEED * length / v_max,
                   math.sqrt(QUINTIC_ACCELERATION * length / a_max))
    n = math.ceil(duration * rate - 1e-9)
    if n <= 0:
        return np.zeros(1)
    tau = np.arange(n + 1) / n
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def rest_to_rest(a: np.ndarray, b: np.ndarray, v_max: float, a_max: float,
                 rate: float) -> np.ndarray:
    """The straight move a → b (3,) as a minimum-jerk profile sampled at ``rate``: (n + 1, 3)
    positions (:func:`_quintic`); just a (1, 3) when a = b."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    s = _quintic(float(np.linalg.norm(b - a)), v_max, a_max, rate)
    out = a + s[:, None] * (b - a)
    if len(s) > 1:
        out[-1] = b
    return out


def _angle(n_a: np.ndarray, n_b: np.ndarray) -> float:
    """The angle (rad) between two unit vectors, accurate near 0 and π."""
    return float(np.arctan2(np.linalg.norm(np.cross(n_a, n_b)), float(n_a @ n_b)))


def turning_move(a: np.ndarray, b: np.ndarray, n_a: np.ndarray, n_b: np.ndarray,
                 v_max: float, a_max: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """The move a → b (3,) that also turns the pen from −n_a to −n_b (unit (3,)): positions
    and normals (n + 1, 3), both along one minimum-jerk profile s(τ) (module docstring:
    turning), lasting as :func:`rest_to_rest` over max(|b − a|, TURN_RADIUS·θ)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    theta = _angle(n_a, n_b)
    s = _quintic(max(float(np.linalg.norm(b - a)), TURN_RADIUS * theta), v_max, a_max, rate)
    if len(s) == 1:  # neither moves nor turns: one period, to join the samples around it
        s = np.array([0.0, 1.0])
    n = len(s) - 1
    position = a + s[:, None] * (b - a)
    position[-1] = b
    if theta < SAME_AXIS:
        return position, np.repeat(np.asarray(n_b, dtype=float)[None], n + 1, axis=0)
    normal = (np.sin((1.0 - s) * theta)[:, None] * n_a
              + np.sin(s * theta)[:, None] * n_b) / math.sin(theta)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    normal[0], normal[-1] = n_a, n_b
    return position, normal


def time_drawing(drawing: Drawing, setup: RobotSetup, start: np.ndarray | None = None,
                 mapping: PaperMapping | None = None,
                 start_normal: np.ndarray | None = None) -> CartesianTrajectory:
    """The pen-tip program of ``drawing`` on ``setup``'s paper at the control rate: from
    ``start`` (3,) m (default: ``pen_up`` + 5 cm above the first stroke's start), for each
    stroke a transfer above its start, lowering, the stroke, lifting; then back to
    ``start``. ``start_normal`` (3,): the pen points along −start_normal at ``start`` (the
    home pose's axis), and the first and last moves turn it (module docstring: turning);
    default: the plane's normal throughout. See the module docstring for the time scale
    and the moves; ``info`` holds its figures."""
    mapping = mapping or PaperMapping.from_canvas(drawing.canvas, setup.paper, setup.margin)
    rate, plane = float(setup.control_rate), setup.plane
    strokes = [support(plan) for plan in drawing.plans]
    assert strokes, "a drawing has at least one plan"

    peaks = [_peaks(*_tip(s, s.grid, mapping, setup)[1:]) for s in strokes]
    peak_speed = max(p[0] for p in peaks)
    peak_acc = max(p[1] for p in peaks)
    k, limiting = time_scale(peak_speed, peak_acc, SAFETY * setup.v_max, SAFETY * setup.a_max)
    if k == 0.0:
        k = min(1.0, MAX_DOT_S / max(s.t_b - s.t_a for s in strokes))
    for _ in range(5):  # the control samples must be within the limits themselves
        sampled = [_sample(s, k, rate, mapping, setup) for s in strokes]
        worst = max(max(speed / setup.v_max, math.sqrt(acc / setup.a_max))
                    for _, speed, acc in sampled)
        if worst <= 1.0:
            break
        k *= worst * (1.0 + 1e-6)
    else:
        raise AssertionError(f"time scale {k} does not converge")  # pragma: no cover

    to_base = plane.to_base
    draws = [to_base(p[:, :2], p[:, 2]) for p, _, _ in sampled]  # (n_i + 1, 3) each
    above = [(to_base(p[[0], :2], setup.pen_up)[0], to_base(p[[-1], :2], setup.pen_up)[0])
             for p, _, _ in sampled]
    if start is None:
        start = to_base(sampled[0][0][[0], :2], setup.pen_up + START_CLEARANCE)[0]
    start = np.asarray(start, dtype=float).reshape(3)

    def move(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return rest_to_rest(a, b, setup.v_max, setup.a_max, rate)

    def touch_down(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return rest_to_rest(a, b, min(TOUCH_SPEED, setup.v_max), setup.a_max, rate)

    n_plane = plane.normal / np.linalg.norm(plane.normal)
    n_start = n_plane if start_normal is None else (
        np.asarray(start_normal, dtype=float) / np.linalg.norm(start_normal))
    turns = _angle(n_start, n_plane) >= SAME_AXIS
    turned: dict[int, np.ndarray] = {}  # segment index -> its normals, where the pen turns

    def turn(a: np.ndarray, b: np.ndarray, n_a: np.ndarray, n_b: np.ndarray) -> np.ndarray:
        points, normals = turning_move(a, b, n_a, n_b, setup.v_max, setup.a_max, rate)
        turned[len(segments)] = normals
        return points

    segments: list[tuple[np.ndarray, int]] = []  # (positions, stroke index or −1)
    here = start
    for i, (draw, (over_start, over_end)) in enumerate(zip(draws, above, strict=True)):
        hover = to_base(sampled[i][0][[0], :2], TOUCH_GAP)[0]
        first = (turn(here, over_start, n_start, n_plane) if i == 0 and turns
                 else move(here, over_start))
        segments.append((first, -1))
        segments += [(move(over_start, hover), -1),
                     (touch_down(hover, draw[0]), -1), (draw, i),
                     (move(draw[-1], over_end), -1)]
        here = over_end
    segments.append((turn(here, start, n_plane, n_start) if turns else move(here, start), -1))

    # each segment starts where the previous one ends: keep that sample once
    position = np.concatenate([start[None]] + [points[1:] for points, _ in segments])
    axis = None
    if turns:
        axis = np.concatenate([n_start[None]] + [
            turned[k][1:] if k in turned else np.repeat(n_plane[None], len(points) - 1, axis=0)
            for k, (points, _) in enumerate(segments)])
    stroke = np.concatenate([[-1]] + [np.full(len(points) - 1, index)
                                      for points, index in segments]).astype(int)
    for i in range(len(draws)):  # a stroke's first sample, on the paper, belongs to it
        stroke[np.flatnonzero(stroke == i)[0] - 1] = i
    n = len(position)
    drawing_s = sum(len(d) - 1 for d in draws) / rate
    transfer_peaks = [_move_peaks(p, rate) for p, i in segments if i < 0]
    uv_drawn = np.concatenate([p[:, :2] for p, _, _ in sampled])
    outside = np.maximum(np.maximum(-uv_drawn, uv_drawn - np.asarray(setup.paper)), 0.0)
    info = {
        "time_scale": k,
        "limiting": limiting,
        "drawing_s": drawing_s,
        "transfer_s": (n - 1) / rate - drawing_s,
        "total_s": (n - 1) / rate,
        "peak_speed": max([peak_speed / k] + [p[0] for p in transfer_peaks]),
        "peak_acc": max([peak_acc / k**2] + [p[1] for p in transfer_peaks]),
        "drawing_peak_speed": peak_speed / k,
        "drawing_peak_acc": peak_acc / k**2,
        "scale_m_per_px": mapping.scale,
        "outside_paper_m": float(np.linalg.norm(outside, axis=1).max()),
        "v_max": setup.v_max,
        "a_max": setup.a_max,
        "strokes": len(strokes),
        "samples": n,
    }
    return CartesianTrajectory(t=np.arange(n) / rate, position=position,
                               pen_down=stroke >= 0, stroke=stroke, normal=plane.normal.copy(),
                               rate=rate, time_scale=k, info=info, axis=axis)


def _move_peaks(points: np.ndarray, rate: float) -> tuple[float, float]:
    """Exact peak speed and acceleration of a :func:`rest_to_rest` move (n + 1, 3)."""
    n = len(points) - 1
    if n == 0:
        return 0.0, 0.0
    length = float(np.linalg.norm(points[-1] - points[0]))
    duration = n / rate
    return QUINTIC_SPEED * length / duration, QUINTIC_ACCELERATION * length / duration**2
