"""Pinocchio's Panda with a pen: the 7 arm joints (fingers locked), a ``pen_tip`` frame
``pen_length`` m along the flange z axis, forward kinematics and Jacobians of that frame,
and a cheap reachability pre-check run before any motion is planned.

The pen points along the flange z axis, so the drawing pose is "tip at x, z axis = −normal";
the rotation about the pen axis is free (5 constrained degrees of freedom out of 7).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from inkmotion.errors import InputError
from inkmotion.robot.panda import ARM_JOINTS, FLANGE, panda_urdf

PEN_TIP = "pen_tip"
_SHOULDER_JOINT = "panda_joint2"
_ELBOW_JOINT = "panda_joint4"
_WRIST_JOINT = "panda_joint6"
_LAST_JOINT = "panda_joint7"


@dataclass(frozen=True)
class PenModel:
    """The reduced Panda model with its pen frame. ``lower``/``upper`` are the joint
    position limits (7,) rad of the URDF; ``frame`` the id of ``pen_tip``."""

    model: pin.Model
    frame: int
    pen_length: float
    lower: np.ndarray  # (7,)
    upper: np.ndarray  # (7,)


@functools.cache
def _arm_model() -> pin.Model:
    """The Panda URDF reduced to the 7 arm joints, the fingers locked closed (parsed once)."""
    full = pin.buildModelFromUrdf(str(panda_urdf()))
    locked = [full.getJointId(name) for name in full.names[1:] if name not in ARM_JOINTS]
    arm = pin.buildReducedModel(full, locked, pin.neutral(full))
    assert tuple(arm.names[1:]) == ARM_JOINTS, arm.names
    return arm


@functools.lru_cache(maxsize=8)
def pen_model(pen_length: float) -> PenModel:
    """The arm model with a ``pen_tip`` frame at ``pen_length`` m along the flange's z axis
    (cached per pen length; treat it as read-only)."""
    model = pin.Model(_arm_model())
    flange_id = model.getFrameId(FLANGE)
    flange = model.frames[flange_id]
    tip = flange.placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, float(pen_length)]))
    frame = model.addFrame(pin.Frame(PEN_TIP, flange.parentJoint, flange_id, tip,
                                     pin.FrameType.OP_FRAME))
    return PenModel(model, frame, float(pen_length), model.lowerPositionLimit.copy(),
                    model.upperPositionLimit.copy())


def pen_poses(pen: PenModel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics of the pen tip for configurations ``q`` (N, 7): positions (N, 3)
    m and pen axes (N, 3), the tip frame's z axis, both in the base frame."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    data = pen.model.createData()
    positions = np.empty((len(q), 3))
    axes = np.empty((len(q), 3))
    for i, qi in enumerate(q):
        pin.forwardKinematics(pen.model, data, qi)
        pose = pin.updateFramePlacement(pen.model, data, pen.frame)
        positions[i] = pose.translation
        axes[i] = pose.rotation[:, 2]
    return positions, axes


def pen_jacobians(pen: PenModel, q: np.ndarray, data: pin.Data | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pen-tip positions (K, 3), axes (K, 3) and frame Jacobians (K, 6, 7) at ``q`` (K, 7).

    Pinocchio's ``computeFrameJacobian`` in ``LOCAL_WORLD_ALIGNED``: rows 0–2 are the tip's
    linear velocity, rows 3–5 the angular velocity ω, both in base axes, so the axis a moves
    as ȧ = ω × a. ``data``: a workspace to reuse (``pen.model.createData()``).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    data = data if data is not None else pen.model.createData()
    positions = np.empty((len(q), 3))
    axes = np.empty((len(q), 3))
    jacobians = np.empty((len(q), 6, pen.model.nv))
    for i, qi in enumerate(q):
        jacobians[i] = pin.computeFrameJacobian(pen.model, data, qi, pen.frame,
                                                pin.LOCAL_WORLD_ALIGNED)
        pose = data.oMf[pen.frame]
        positions[i] = pose.translation
        axes[i] = pose.rotation[:, 2]
    return positions, axes, jacobians


def _joint_origins(pen: PenModel, q: np.ndarray) -> dict[str, np.ndarray]:
    data = pen.model.createData()
    pin.forwardKinematics(pen.model, data, q)
    return {name: data.oMi[pen.model.getJointId(name)].translation.copy()
            for name in (_SHOULDER_JOINT, _ELBOW_JOINT, _WRIST_JOINT, _LAST_JOINT)}


@functools.lru_cache(maxsize=8)
def reach_interval(pen_length: float, joint_margin: float = 0.0) -> tuple[float, float, float]:
    """(shoulder height m, r_min, r_max): the distances from the shoulder (joint 2's origin,
    fixed in the base) at which joint 7's origin can be.

    The shoulder–wrist distance |o6 − o2| depends on the elbow angle q4 only, so its range
    over q4 ∈ [lower + margin, upper − margin] is exact; joint 7 sits a fixed offset ℓ from
    joint 6, hence r ∈ [min|o6 − o2| − ℓ, max|o6 − o2| + ℓ] (a necessary condition).
    """
    pen = pen_model(pen_length)
    elbow = pen.model.joints[pen.model.getJointId(_ELBOW_JOINT)].idx_q
    lo, hi = pen.lower[elbow] + joint_margin, pen.upper[elbow] - joint_margin
    spans = []
    for angle in np.linspace(lo, hi, 721):
        q = np.zeros(pen.model.nq)
        q[elbow] = angle
        origins = _joint_origins(pen, q)
        spans.append(np.linalg.norm(origins[_WRIST_JOINT] - origins[_SHOULDER_JOINT]))
    origins = _joint_origins(pen, np.zeros(pen.model.nq))
    offset = np.linalg.norm(origins[_LAST_JOINT] - origins[_WRIST_JOINT])  # fixed in link 6
    shoulder = origins[_SHOULDER_JOINT]
    assert np.allclose(shoulder[:2], 0.0)  # on joint 1's axis: fixed in the base
    return float(shoulder[2]), float(min(spans) - offset), float(max(spans) + offset)


def _tip_to_last_joint(pen: PenModel) -> tuple[float, float]:
    """Joint 7's origin seen from the pen tip: (distance along the pen axis, sideways
    distance), from the tip frame's placement in joint 7's frame."""
    placement = pen.model.frames[pen.frame].placement
    origin = -placement.rotation.T @ placement.translation  # joint 7 origin, tip frame
    return float(-origin[2]), float(np.hypot(origin[0], origin[1]))


def check_reachable(positions: np.ndarray, normal: np.ndarray, pen_length: float, *,
                    joint_margin: float = 0.0, stroke: np.ndarray | None = None) -> None:
    """Raise ``InputError`` naming the first pen-tip position (N, 3) m that the Panda cannot
    reach with the pen along −``normal`` ((3,), or (N, 3) one per position): with the pen
    axis fixed, joint 7's origin is w = x + (pen_length + flange)·n, and |w − shoulder|
    must lie in ``reach_interval``.
    Cheap (vectorised, no IK); necessary, not sufficient — the solver checks the rest."""
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    n = np.asarray(normal, dtype=float)  # (3,), or (N, 3): one per position
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    height, r_min, r_max = reach_interval(float(pen_length), float(joint_margin))
    along, sideways = _tip_to_last_joint(pen_model(float(pen_length)))
    wrist = positions + along * n
    r = np.linalg.norm(wrist - np.array([0.0, 0.0, height]), axis=1)
    bad = np.flatnonzero((r > r_max + sideways) | (r < r_min - sideways))
    if len(bad) == 0:
        return
    k = int(bad[0])
    where = f"sample {k}"
    if stroke is not None and int(stroke[k]) >= 0:
        where += f" (stroke {int(stroke[k])})"
    x, y, z = positions[k]
    far = r[k] > r_max
    fix = "closer to the robot or scale the paper down" if far else "away from the robot's base"
    raise InputError(
        f"The pen tip at {where}, ({x:.3f}, {y:.3f}, {z:.3f}) m in the robot's base frame, is "
        f"out of the Panda's reach (its wrist would be {r[k]:.3f} m from the shoulder, "
        f"allowed {r_min:.3f}–{r_max:.3f} m); move the drawing plane {fix}.")
