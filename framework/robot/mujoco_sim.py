"""Executing a joint trajectory in MuJoCo with a joint impedance controller at 1 kHz (paper,
"Executing ΣΛ trajectories with a robot": "tracked by an impedance controller ... torque
commands ... at a 1kHz rate"), and the figures of that execution.

Controller, at every simulation step (the model's own dynamics, as libfranka's
``coriolis`` + ``gravity`` would give them on the real arm)::

    τ = Kp (q_d − q) + Kd (q̇_d − q̇) + [C(q, q̇) q̇ + g(q)] + M(q) q̈_d + D q̇_d

``C q̇ + g`` is ``data.qfrc_bias``, ``M q̈_d`` the inertia feed-forward through
``mujoco.mj_mulM`` (``feedforward=False`` drops it and ``D q̇_d``, the joints' viscous
damping at the desired velocity), and τ is clipped by the motors' ctrlrange (the Panda's
torque limits). q̇_d and q̈_d are derivatives of a C² cubic spline through ``q_des``,
evaluated at the simulation steps (which also resamples ``q_des`` when its rate is not
1/timestep).

Contact, two readings per step. *Touch* (what inks, and what contact coverage counts): the
signed distance from the pen's rounded tip (a sphere of the pen's radius around
``tip − r·axis``) to the drawing plane is below the scene's ``touch_tolerance`` (0.1 mm) and
its lowest point lies on the board; the ink point is that lowest point projected on the
plane. MuJoCo's own
contact (a pen/board pair in ``data.contact``, i.e. penetration) gives the normal force
(``mj_contactForce``); it is not used for touch because a pen sliding under the soft contact
chatters by a few µm across zero distance, which would break a continuous line into dots.

Pressing matters for the drawing: under joint impedance the pen tip's Cartesian compliance
J Kp⁻¹ Jᵀ couples the plane's normal with in-plane directions (about 1:1 in the tests'
poses, ~1.5 N/mm normal stiffness), so a plan that presses d mm into the board draws about
d mm off its line, which the in-plane tracking error below shows.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
from scipy.interpolate import CubicSpline

from inkmotion.robot import limits
from inkmotion.robot.scene import Scene
from inkmotion.robot.tracking import error_stats, trim

#: joint stiffness of libfranka's joint impedance example (stiff shoulder, soft wrist)
KP = np.array([600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0])  # N·m/rad
#: damping above libfranka's example (50, 50, 50, 50, 30, 25, 15): at home the damping
#: ratios are 1.3–3.3, and a pen sliding under friction stops hopping (test_robot_sim)
KD = np.array([80.0, 80.0, 80.0, 80.0, 40.0, 30.0, 15.0])  # N·m·s/rad


@dataclass
class SimResult:
    """What one execution recorded, one row per simulation step (state at the step's start,
    the command applied during it, the contacts detected at that state)."""

    t: np.ndarray  # (N,) s
    q: np.ndarray  # (N, 7) rad
    qd: np.ndarray  # (N, 7) rad/s
    qdd: np.ndarray  # (N, 7) rad/s², the acceleration the step integrated
    tau: np.ndarray  # (N, 7) N·m, commanded torque after clipping
    saturated: np.ndarray  # (N,) bool, some joint's torque hit its limit
    q_des: np.ndarray  # (N, 7) rad, the reference at the simulation steps
    tip: np.ndarray  # (N, 3) m, executed pen tip (site ``pen_tip``)
    flange: np.ndarray  # (N, 3) m, executed flange origin (panda_link8)
    commanded_tip: np.ndarray  # (N, 3) m, pen tip of q_des (forward kinematics)
    commanded_flange: np.ndarray  # (N, 3) m, flange of q_des
    contact: np.ndarray  # (N,) bool, pen touches the board (distance < touch tolerance)
    contact_pos: np.ndarray  # (N, 3) m, ink point on the plane (NaN without touch)
    pen_gap: np.ndarray  # (N,) m, signed distance pen tip - plane (< 0: pressed in)
    penetrating: np.ndarray  # (N,) bool, MuJoCo has a pen/board contact pair
    contact_force: np.ndarray  # (N,) N, normal force of that pair (0 without)
    normal: np.ndarray  # (3,) drawing plane normal (away from the board)
    timestep: float  # s
    wall_s: float  # s, wall time of the simulation loop
    pose_t: np.ndarray  # (P,) s, times of the link poses (pose_rate)
    pose_pos: np.ndarray  # (P, B, 3) m, mesh frame positions
    pose_quat: np.ndarray  # (P, B, 4) mesh frame orientations, w x y z (MuJoCo order)
    link_names: tuple[str, ...]  # (B,) body names, the columns of pose_pos / pose_quat
    meshes: dict[str, Path] = field(default_factory=dict)  # body name -> STL
    info: dict = field(default_factory=dict)  # controller settings

    @property
    def duration(self) -> float:
        """Simulated time, s."""
        return len(self.t) * self.timestep

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second (> 1: faster than real time)."""
        return self.duration / max(self.wall_s, 1e-12)

    @property
    def contact_points(self) -> np.ndarray:
        """(K, 3) m, the contact points of the steps that touched, in time order."""
        return self.contact_pos[self.contact]

    def contact_strokes(self) -> list[np.ndarray]:
        """The contact points split into runs of consecutive touching steps: the ink lines
        (each (k_i, 3) m)."""
        index = np.flatnonzero(self.contact)
        if index.size == 0:
            return []
        breaks = np.flatnonzero(np.diff(index) > 1) + 1
        return [self.contact_pos[run] for run in np.split(index, breaks)]

    def link_meshes(self) -> dict[str, Path]:
        """Body name → collision STL; its vertices are in the frame ``link_poses`` gives."""
        return dict(self.meshes)

    def link_poses(self, j: int) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Body name → (position (3,), quaternion w x y z (4,)) of its mesh frame at
        ``pose_t[j]``."""
        return {name: (self.pose_pos[j, b], self.pose_quat[j, b])
                for b, name in enumerate(self.link_names)}


def reference(q_des: np.ndarray, rate: float, timestep: float,
              settle: float = 0.0) -> tuple[np.ndarray, ...]:
    """q_d, q̇_d, q̈_d at the simulation steps: a C² cubic spline through ``q_des`` sampled
    at ``rate`` (held at its last sample for ``settle`` s). Returns (t, q, qd, qdd)."""
    q_des = np.asarray(q_des, dtype=float)
    assert q_des.ndim == 2 and q_des.shape[1] == 7, f"q_des must be (N, 7), got {q_des.shape}"
    assert len(q_des) >= 2, "q_des needs at least two samples"
    t_plan = np.arange(len(q_des)) / rate
    spline = CubicSpline(t_plan, q_des, axis=0)
    n_sim = int(np.floor(t_plan[-1] / timestep + 1e-9)) + 1
    t = np.arange(n_sim) * timestep
    q, qd, qdd = spline(t), spline(t, 1), spline(t, 2)
    n_settle = int(round(settle / timestep))
    if n_settle > 0:
        t = np.arange(n_sim + n_settle) * timestep
        q = np.vstack([q, np.repeat(q_des[-1:], n_settle, axis=0)])
        qd = np.vstack([qd, np.zeros((n_settle, 7))])
        qdd = np.vstack([qdd, np.zeros((n_settle, 7))])
    return t, q, qd, qdd


def forward_points(scene: Scene, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pen tip and flange positions (N, 3) of joint configurations ``q`` (N, 7)."""
    model = scene.model
    data = mujoco.MjData(model)
    tip, flange = np.empty((len(q), 3)), np.empty((len(q), 3))
    for k, qk in enumerate(q):
        data.qpos[scene.qpos_adr] = qk
        mujoco.mj_kinematics(model, data)
        tip[k] = data.site_xpos[scene.pen_tip_site]
        flange[k] = data.xpos[scene.flange_body]
    return tip, flange


def pen_touch(scene: Scene, tip: np.ndarray,
              axis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed gap (N,) m between the pen's rounded tip and the plane, the ink point (N, 3)
    (the tip's lowest point projected on the plane; NaN where not touching) and touch (N,)
    bool, from tip positions and pen axes (N, 3): the tip is a sphere of radius r centred
    at ``tip − r·axis``."""
    r, n = scene.pen_radius, scene.normal
    lowest = tip - r * axis - r * n  # (N, 3)
    gap = (lowest - scene.board_origin) @ n
    u, v = ((lowest - scene.board_origin) @ scene.board_rotation[:, :2]).T
    u_min, u_max, v_min, v_max = scene.board_extent
    touch = (gap < scene.touch_tolerance) & (u >= u_min) & (u <= u_max) & (v >= v_min) & (
        v <= v_max)
    points = np.where(touch[:, None], lowest - gap[:, None] * n, np.nan)
    return gap, points, touch


def simulate(scene: Scene, q_des: np.ndarray, rate: float, *, kp: np.ndarray = KP,
             kd: np.ndarray = KD, feedforward: bool = True, settle: float = 0.0,
             pose_rate: float = 50.0) -> SimResult:
    """Run ``q_des`` (N, 7) sampled at ``rate`` Hz on the scene's Panda from rest at
    ``q_des[0]``, one impedance-controller update per simulation step (module docstring),
    and record the execution. Link poses are kept at ``pose_rate`` Hz for a replay."""
    model = scene.model
    dt = model.opt.timestep
    t, ref_q, ref_qd, ref_qdd = reference(q_des, rate, dt, settle)
    n = len(t)
    kp, kd = np.asarray(kp, dtype=float), np.asarray(kd, dtype=float)
    qa, da, act = scene.qpos_adr, scene.dof_adr, scene.actuators
    damping = model.dof_damping[da] if feedforward else np.zeros(7)
    lo, hi = model.actuator_ctrlrange[act].T

    data = mujoco.MjData(model)
    data.qpos[qa] = ref_q[0]
    mujoco.mj_forward(model, data)

    rec_q, rec_qd, rec_qdd, rec_tau = (np.empty((n, 7)) for _ in range(4))
    tip, flange, axis = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    penetrating = np.zeros(n, dtype=bool)
    contact_force = np.zeros(n)
    pose_every = max(1, int(round(1.0 / (pose_rate * dt))))
    pose_steps = np.arange(0, n, pose_every)
    bodies = np.array([f.body for f in scene.mesh_frames])
    body_pos = np.empty((len(pose_steps), len(bodies), 3))
    body_quat = np.empty((len(pose_steps), len(bodies), 4))
    pen_board = {scene.pen_geom, scene.board_geom}
    qacc_des = np.zeros(model.nv)
    m_qdd = np.zeros(model.nv)
    force6 = np.zeros(6)

    start = time.perf_counter()
    for k in range(n):
        mujoco.mj_step1(model, data)  # kinematics, M, bias forces, collisions at t_k
        q, v = data.qpos[qa], data.qvel[da]
        rec_q[k], rec_qd[k] = q, v
        tip[k] = data.site_xpos[scene.pen_tip_site]
        axis[k] = data.site_xmat[scene.pen_tip_site][2::3]  # the pen's axis, site z
        flange[k] = data.xpos[scene.flange_body]
        if k % pose_every == 0:
            body_pos[k // pose_every] = data.xpos[bodies]
            body_quat[k // pose_every] = data.xquat[bodies]
        tau = kp * (ref_q[k] - q) + kd * (ref_qd[k] - v) + data.qfrc_bias[da]
        if feedforward:
            qacc_des[da] = ref_qdd[k]
            mujoco.mj_mulM(model, data, m_qdd, qacc_des)
            tau += m_qdd[da] + damping * ref_qd[k]
        tau = np.clip(tau, lo, hi)
        rec_tau[k] = tau
        data.ctrl[act] = tau
        mujoco.mj_step2(model, data)  # constraint forces, integrate to t_{k+1}
        rec_qdd[k] = data.qacc[da]
        for i in range(data.ncon):
            c = data.contact[i]
            if {int(c.geom[0]), int(c.geom[1])} == pen_board and c.efc_address >= 0:
                mujoco.mj_contactForce(model, data, i, force6)
                penetrating[k] = True
                contact_force[k] += force6[0]
    wall = time.perf_counter() - start

    pen_gap, contact_pos, contact = pen_touch(scene, tip, axis)
    commanded_tip, commanded_flange = forward_points(scene, ref_q)
    pose_pos, pose_quat = _mesh_poses(scene, body_pos, body_quat)
    saturated = np.any((rec_tau <= lo + 1e-9) | (rec_tau >= hi - 1e-9), axis=1)
    return SimResult(
        t=t, q=rec_q, qd=rec_qd, qdd=rec_qdd, tau=rec_tau, saturated=saturated, q_des=ref_q,
        tip=tip, flange=flange, commanded_tip=commanded_tip,
        commanded_flange=commanded_flange, contact=contact, contact_pos=contact_pos,
        pen_gap=pen_gap, penetrating=penetrating, contact_force=contact_force,
        normal=scene.normal.copy(), timestep=dt, wall_s=wall,
        pose_t=pose_steps * dt, pose_pos=pose_pos, pose_quat=pose_quat,
        link_names=tuple(f.name for f in scene.mesh_frames), meshes=scene.link_meshes(),
        info={"kp": kp.tolist(), "kd": kd.tolist(), "feedforward": feedforward,
              "rate_hz": float(rate), "sim_rate_hz": 1.0 / dt, "settle_s": settle,
              "pose_rate_hz": 1.0 / (pose_every * dt)},
    )


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions (..., 4) in w x y z order."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def _quat_rotate(quat: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Rotate vectors (..., 3) by unit quaternions (..., 4) (w x y z)."""
    w, xyz = quat[..., :1], quat[..., 1:]
    cross = np.cross(xyz, vec)
    return vec + 2.0 * (w * cross + np.cross(xyz, cross))


def _mesh_poses(scene: Scene, body_pos: np.ndarray,
                body_quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Body poses (P, B, ·) composed with each mesh frame's local offset."""
    local_pos = np.stack([f.pos for f in scene.mesh_frames])  # (B, 3)
    local_quat = np.stack([f.quat for f in scene.mesh_frames])  # (B, 4)
    pos = body_pos + _quat_rotate(body_quat, np.broadcast_to(local_pos, body_pos.shape))
    quat = _quat_mul(body_quat, np.broadcast_to(local_quat, body_quat.shape))
    return pos, quat


# ----------------------------------------------------------------------------- metrics


def execution_metrics(sim: SimResult, planned_tip: np.ndarray, pen_down: np.ndarray, *,
                      rate: float | None = None, normal: np.ndarray | None = None,
                      edge_s: float = 0.02) -> dict:
    """Figures of an execution against its plan (planned pen tip (N, 3) m and pen_down
    (N,) at ``rate`` Hz, default the simulation rate; they start at t = 0 like the sim).

    Tracking error e = executed tip − planned tip at the plan's samples, split along the
    plane normal n: ``plane`` = |e − (e·n) n| is what shows on the paper; ``normal`` = e·n
    (signed, + away from the board) is mostly the press depth the board refuses during
    pen-down, so it is reported apart instead of polluting the drawing error. ``tracking_*``
    compares with the planned tip, ``control_*`` with the forward kinematics of q_des
    (the controller alone, without the joint planner's own error). Joint velocity,
    acceleration and jerk (executed: the simulated velocity and acceleration, the jerk their
    finite difference; commanded: finite differences of q_des) and the flange's Cartesian
    speed and acceleration (finite differences) are given against the Panda limits, all by
    :mod:`inkmotion.robot.limits`. Contact coverage is the fraction of pen-down
    samples, ``edge_s`` away from a stroke's start and end, where the pen touches; spurious
    contact the same over pen-up samples.
    """
    planned_tip = np.asarray(planned_tip, dtype=float)
    pen_down = np.asarray(pen_down, dtype=bool)
    assert planned_tip.shape == (len(pen_down), 3), "planned_tip must be (N, 3) like pen_down"
    dt = sim.timestep
    rate = 1.0 / dt if rate is None else float(rate)
    n = normal if normal is not None else sim.normal
    n = np.asarray(n, dtype=float) / np.linalg.norm(n)

    t_plan = np.arange(len(pen_down)) / rate
    index = np.clip(np.round(t_plan / dt).astype(int), 0, len(sim.t) - 1)
    executed = np.stack([np.interp(t_plan, sim.t, sim.tip[:, i]) for i in range(3)], axis=1)
    commanded = sim.commanded_tip[index]
    everything = np.ones(len(pen_down), dtype=bool)
    metrics: dict = {}
    for prefix, err in (("tracking", executed - planned_tip), ("control", executed - commanded)):
        metrics.update(error_stats(err, pen_down, n, f"{prefix}_down"))
        metrics.update(error_stats(err, ~pen_down, n, f"{prefix}_up"))
        metrics.update(error_stats(err, everything, n, f"{prefix}_all"))
    joint_err = np.abs(sim.q - sim.q_des)
    metrics["joint_error_max_rad"] = joint_err.max(axis=0).tolist()
    metrics["joint_error_rms_rad"] = float(np.sqrt(np.mean(joint_err**2)))

    sim_rate = 1.0 / dt
    for name, value in (("velocity", np.abs(sim.qd).max(axis=0)),
                        ("acceleration", np.abs(sim.qdd).max(axis=0)),
                        ("jerk", limits.peak(sim.qdd, sim_rate, 1))):
        metrics.update(limits.limit_figures(f"executed_joint_{name}", value,
                                            limits.JOINT_LIMITS[name][1]))
    for name, (order, limit) in limits.JOINT_LIMITS.items():
        metrics.update(limits.limit_figures(f"commanded_joint_{name}",
                                            limits.peak(sim.q_des, sim_rate, order), limit))
    for name, points in (("executed", sim.flange), ("commanded", sim.commanded_flange)):
        speed = limits.peak_norm(points, sim_rate, 1)
        accel = limits.peak_norm(points, sim_rate, 2)
        metrics[f"{name}_flange_speed_max"] = speed
        metrics[f"{name}_flange_speed_ratio"] = speed / limits.CARTESIAN_SPEED_LIMIT
        metrics[f"{name}_flange_acceleration_max"] = accel
        metrics[f"{name}_flange_acceleration_ratio"] = (
            accel / limits.CARTESIAN_ACCELERATION_LIMIT)

    margin = int(round(edge_s * rate))
    touching = sim.contact[index]
    inner_down, inner_up = trim(pen_down, margin), trim(~pen_down, margin)
    metrics["contact_coverage"] = float(touching[inner_down].mean()) if inner_down.any() else 0.0
    metrics["spurious_contact"] = float(touching[inner_up].mean()) if inner_up.any() else 0.0
    forces = sim.contact_force[index][pen_down & touching]
    metrics["contact_force_mean_n"] = float(forces.mean()) if forces.size else 0.0
    metrics["contact_force_max_n"] = float(forces.max()) if forces.size else 0.0
    metrics["torque_saturation_fraction"] = float(sim.saturated.mean())
    metrics["sim_time_s"] = sim.duration
    metrics["wall_time_s"] = sim.wall_s
    metrics["real_time_factor"] = sim.real_time_factor
    metrics["wall_s_per_sim_s"] = sim.wall_s / max(sim.duration, 1e-12)
    return metrics
