"""The MuJoCo scene of a drawing run, built at run time: the Panda of example-robot-data
(collision STL meshes), a pen on its flange and a fixed board whose top face is the
calibrated drawing plane.

The URDF is rewritten in memory before MuJoCo reads it: visuals (DAE, unreadable by MuJoCo)
are dropped, mesh paths become STL file names under the collision mesh folder, the finger
joints become fixed (the fingers hold the pen, opened by its radius) and a ``<mujoco>``
compiler element keeps the static bodies (``panda_link8``, ``panda_hand``) so the pen can
be mounted on the flange. The rest is added with ``mujoco.MjSpec``:

- joint armature (reflected rotor inertia) and viscous damping, torque motors (gear 1,
  ``ctrlrange`` = the Panda's 87/12 N·m limits) on the seven arm joints;
- a pen capsule along the flange's z axis whose rounded end reaches ``pen_length`` (the
  ``pen_tip`` site), and the board: a thin box sized to the paper plus a border.

Contacts: the arm's geoms have ``contype = conaffinity = 0`` (no self or board contact: the
hand may graze the board in a steep pose without disturbing the drawing); the pen and the
board share bit 2, so the only contact pair the simulation can produce is pen/board.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from inkmotion.robot import panda

#: Panda joint torque limits (datasheet), N·m
TORQUE_LIMITS = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])
#: reflected rotor inertia per joint, kg·m² (a common value for the Panda's drives)
ARMATURE = 0.1
#: viscous joint damping, N·m·s/rad (the controller feeds it forward at q̇_d)
DAMPING = 0.5
#: the contact bit shared by the pen and the board only
_PEN_BOARD_BIT = 2
#: pen-board distance below which the pen counts as touching (inks), m: the soft contact
#: settles at µm penetrations and a sliding pen chatters by a few µm, so a strict
#: ``dist < 0`` would flicker where the ink line is continuous
TOUCH_TOLERANCE = 1e-4
#: sliding, torsional, rolling friction of a felt pen on paper
#: sliding, torsional, rolling friction of the pen on the board. Sliding 0.1 (a felt tip on
#: paper): at 0.3 the pen stick-slips on 49867.json (contact force peaks 38 N against a mean
#: of 1 N, joint 4 at 1.12× its acceleration limit); at 0.1 the peaks are 12 N and every
#: joint keeps ≥ 27 % margin to its acceleration limit, with the same tracking error.
_PEN_FRICTION = (0.1, 0.005, 0.0001)
#: contact softness (time constant s, damping ratio): MuJoCo's default 20 ms, critically
#: damped, stands for the felt tip and the paper's give; a stiff 4 ms contact makes the
#: arm bounce off the board at touch-down (0.7 mm rebound, about half of a line inked)
_CONTACT_SOLREF = (0.02, 1.0)
#: where the pen's barrel starts along the flange z axis (inside the hand), m
_PEN_START = 0.05
_PEN_MASS = 0.02  # kg


@dataclass(frozen=True)
class MeshFrame:
    """A collision STL of the arm and the frame its vertices are given in: the pose of body
    ``body`` composed with the local offset ``pos``/``quat`` (w, x, y, z)."""

    name: str  # body name
    body: int  # body id
    mesh: Path  # STL file
    pos: np.ndarray  # (3,)
    quat: np.ndarray  # (4,) w, x, y, z


@dataclass(frozen=True)
class Scene:
    """A compiled drawing scene and the ids a controller and a recorder need."""

    model: mujoco.MjModel
    pen_tip_site: int  # site at the pen tip
    flange_body: int  # panda_link8
    board_geom: int
    pen_geom: int
    arm_joints: np.ndarray  # (7,) joint ids, panda_joint1..7
    qpos_adr: np.ndarray  # (7,) addresses in qpos
    dof_adr: np.ndarray  # (7,) addresses in qvel / qfrc
    actuators: np.ndarray  # (7,) actuator ids, in joint order
    board_origin: np.ndarray  # (3,) a point of the drawing plane (board top face)
    board_rotation: np.ndarray  # (3, 3) columns u, v, normal
    paper: tuple[float, float]  # (w, h) m
    board_extent: tuple[float, float, float, float]  # top face: u_min, u_max, v_min, v_max m
    pen_length: float  # m, tip from the flange origin along its z axis
    pen_radius: float  # m, also the radius of the pen's rounded tip
    touch_tolerance: float  # m, pen-board distance that still counts as touching
    mesh_frames: tuple[MeshFrame, ...]

    @property
    def normal(self) -> np.ndarray:
        """The drawing plane's unit normal, pointing away from the board (3,)."""
        return self.board_rotation[:, 2]

    def link_meshes(self) -> dict[str, Path]:
        """Body name → collision STL drawn at that body's recorded mesh pose."""
        return {f.name: f.mesh for f in self.mesh_frames}


def _panda_urdf_text(finger_opening: float) -> str:
    """The Panda URDF as MuJoCo can read it: no visuals, STL file names, fixed fingers."""
    root = ET.parse(panda.panda_urdf()).getroot()
    for link in root.findall("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
    for mesh in root.iter("mesh"):
        mesh.set("filename", mesh.get("filename", "").rsplit("/", 1)[-1])
    for joint in root.findall("joint"):
        name = joint.get("name", "")
        if not name.startswith("panda_finger_joint"):
            continue
        axis = np.array([float(a) for a in joint.find("axis").get("xyz").split()])
        origin = joint.find("origin")
        xyz = np.array([float(a) for a in origin.get("xyz").split()]) + finger_opening * axis
        origin.set("xyz", " ".join(f"{c:.6g}" for c in xyz))
        joint.set("type", "fixed")
        for tag in ("axis", "limit", "mimic", "dynamics"):
            for element in joint.findall(tag):
                joint.remove(element)
    extension = ET.SubElement(root, "mujoco")
    ET.SubElement(extension, "compiler", meshdir=str(panda.mesh_dir("collision")),
                  balanceinertia="true", discardvisual="false", fusestatic="false",
                  strippath="false")
    return ET.tostring(root, encoding="unicode")


def _check_frame(origin: np.ndarray, rotation: np.ndarray) -> None:
    assert origin.shape == (3,), f"board_origin must be (3,), got {origin.shape}"
    assert rotation.shape == (3, 3), f"board_rotation must be (3, 3), got {rotation.shape}"
    assert np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-6), "rotation not orthonormal"
    assert np.linalg.det(rotation) > 0, "board_rotation must be right-handed"


def build_scene(*, board_origin: np.ndarray, board_rotation: np.ndarray,
                board_size: tuple[float, float], pen_length: float,
                pen_radius: float = 0.004, timestep: float = 0.001,
                paper_center: tuple[float, float] | None = None, border: float = 0.05,
                board_thickness: float = 0.02,
                contact_solref: tuple[float, float] = _CONTACT_SOLREF,
                friction: float = _PEN_FRICTION[0],
                touch_tolerance: float = TOUCH_TOLERANCE) -> Scene:
    """Compile the drawing scene.

    The paper is the rectangle [0, w] × [0, h] of plane coordinates (u, v) measured from
    ``board_origin`` along the first two columns of ``board_rotation`` (pass
    ``paper_center`` in (u, v) m if the calibration puts the origin elsewhere); the board
    extends ``border`` beyond it and its top face is the plane (third column = normal,
    pointing away from the board). ``pen_length`` is the tip's distance from the
    ``panda_link8`` origin along its z axis; ``pen_radius`` is the pen's and its rounded
    tip's radius. ``contact_solref`` and ``friction`` set the pen/board contact (module
    constants say why); ``touch_tolerance`` is the pen-board distance that still inks.
    """
    origin = np.asarray(board_origin, dtype=float)
    rotation = np.asarray(board_rotation, dtype=float)
    _check_frame(origin, rotation)
    w, h = (float(s) for s in board_size)
    assert w > 0 and h > 0, f"board_size must be positive, got {board_size}"
    assert pen_length > _PEN_START + 2 * pen_radius, (
        f"pen_length {pen_length} m does not reach out of the hand")

    spec = mujoco.MjSpec.from_string(_panda_urdf_text(finger_opening=pen_radius))
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.gravity = [0.0, 0.0, -9.81]
    for geom in spec.geoms:
        geom.contype, geom.conaffinity = 0, 0
    for i, name in enumerate(panda.ARM_JOINTS):
        joint = spec.joint(name)
        joint.armature = ARMATURE
        joint.damping = [DAMPING, 0.0, 0.0]  # linear coefficient, no polynomial terms
        motor = spec.add_actuator(name=f"motor{i + 1}", target=name,
                                  trntype=mujoco.mjtTrn.mjTRN_JOINT)
        motor.gear[0] = 1.0
        motor.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        motor.ctrlrange = [-TORQUE_LIMITS[i], TORQUE_LIMITS[i]]

    # the pen is a body of its own, welded to the flange, so its inertia comes from its geom
    pen = spec.body(panda.FLANGE).add_body(name="pen")
    tip_center = pen_length - pen_radius  # the capsule's rounded end reaches pen_length
    contact = {"contype": _PEN_BOARD_BIT, "conaffinity": _PEN_BOARD_BIT,
               "friction": [friction, *_PEN_FRICTION[1:]], "solref": list(contact_solref)}
    pen.add_geom(name="pen", type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[pen_radius, 0, 0],
                 fromto=[0, 0, _PEN_START, 0, 0, tip_center], mass=_PEN_MASS,
                 rgba=[0.1, 0.1, 0.1, 1], **contact)
    pen.add_site(name="pen_tip", pos=[0, 0, pen_length], size=[0.001, 0, 0])

    cu, cv = paper_center if paper_center is not None else (w / 2, h / 2)
    center = origin + rotation @ np.array([cu, cv, -board_thickness / 2])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rotation.reshape(-1))
    spec.worldbody.add_geom(name="board", type=mujoco.mjtGeom.mjGEOM_BOX,
                            size=[w / 2 + border, h / 2 + border, board_thickness / 2],
                            pos=center, quat=quat, rgba=[0.95, 0.95, 0.9, 1], **contact)
    model = spec.compile()

    def ident(kind: mujoco.mjtObj, name: str) -> int:
        index = mujoco.mj_name2id(model, kind, name)
        assert index >= 0, f"{name} missing from the compiled scene"
        return index

    joints = np.array([ident(mujoco.mjtObj.mjOBJ_JOINT, n) for n in panda.ARM_JOINTS])
    return Scene(
        model=model,
        pen_tip_site=ident(mujoco.mjtObj.mjOBJ_SITE, "pen_tip"),
        flange_body=ident(mujoco.mjtObj.mjOBJ_BODY, panda.FLANGE),
        board_geom=ident(mujoco.mjtObj.mjOBJ_GEOM, "board"),
        pen_geom=ident(mujoco.mjtObj.mjOBJ_GEOM, "pen"),
        arm_joints=joints,
        qpos_adr=model.jnt_qposadr[joints].copy(),
        dof_adr=model.jnt_dofadr[joints].copy(),
        actuators=np.array([ident(mujoco.mjtObj.mjOBJ_ACTUATOR, f"motor{i}")
                            for i in range(1, 8)]),
        board_origin=origin,
        board_rotation=rotation,
        paper=(w, h),
        board_extent=(cu - w / 2 - border, cu + w / 2 + border,
                      cv - h / 2 - border, cv + h / 2 + border),
        pen_length=float(pen_length),
        pen_radius=float(pen_radius),
        touch_tolerance=float(touch_tolerance),
        mesh_frames=_mesh_frames(model),
    )


def _mesh_frames(model: mujoco.MjModel) -> tuple[MeshFrame, ...]:
    """The arm's STL meshes in URDF frames: links 0–7 and the hand carry their own STL in
    the body frame; the fingers (boxes in the URDF's collision) get ``finger.stl``, the
    right one turned by π about z as in the URDF's visual."""
    folder = panda.mesh_dir("collision")
    items = [(f"panda_link{i}", f"link{i}.stl") for i in range(8)]
    items += [("panda_hand", "hand.stl"), ("panda_leftfinger", "finger.stl"),
              ("panda_rightfinger", "finger.stl")]
    frames = []
    for body_name, stl in items:
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body_name)
        quat = np.array([0.0, 0.0, 0.0, 1.0]) if body_name == "panda_rightfinger" else (
            np.array([1.0, 0.0, 0.0, 0.0]))
        frames.append(MeshFrame(name=body_name, body=body, mesh=folder / stl,
                                pos=np.zeros(3), quat=quat))
    return tuple(frames)
