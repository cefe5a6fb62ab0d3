"""The execution replayed in the job's rerun recording, on a ``time`` timeline (seconds):

``robot/links/<body>``      the Panda's collision meshes (Asset3D, static) moved by a
                            Transform3D per recorded pose (send_columns: one chunk per link)
``robot/board``             the board's top face, a static box outline
``robot/planned_path``      the planned pen-tip path while drawing (static LineStrips3D)
``robot/pen_tip``           the simulated pen tip at each recorded pose
``robot/contact_trace``     the ink laid so far: the contact points up to each recorded pose

So ``inkmotion view`` shows the arm drawing; the step timeline holds the planning stages.
A real arm's execution (:func:`log_arm_execution`) is logged from its reported joint
positions: ``robot/arm`` the links as a line through the joint origins (Pinocchio's forward
kinematics), ``robot/pen_tip`` and ``robot/trace`` (the tip's path while within a millimetre
of the plane) on the same timeline, with the planned path and the board as above.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) index ranges where ``mask`` is True."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def log_execution(stream: Any, program: Any, sim: Any, max_trace_points: int = 2000) -> None:
    """Log ``sim`` (a :class:`inkmotion.robot.mujoco_sim.SimResult`) of ``program`` into
    ``stream`` (a rerun RecordingStream)."""
    import rerun as rr

    cart = program.cartesian
    stream.log("robot", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for name, mesh in sim.link_meshes().items():
        stream.log(f"robot/links/{name}", rr.Asset3D(path=str(mesh)), static=True)
    times = rr.TimeColumn("time", duration=sim.pose_t)
    for b, name in enumerate(sim.link_names):
        wxyz = sim.pose_quat[:, b]
        stream.send_columns(f"robot/links/{name}", indexes=[times],
                            columns=rr.Transform3D.columns(
                                translation=sim.pose_pos[:, b],
                                quaternion=np.column_stack((wxyz[:, 1:], wxyz[:, :1]))))
    strips = [cart.position[a:b] for a, b in _runs(cart.pen_down) if b - a >= 2]
    if strips:
        stream.log("robot/planned_path", rr.LineStrips3D(strips, colors=[(80, 80, 220)],
                                                          radii=[0.0006]), static=True)
    plane = program.setup.plane
    w, h = program.setup.paper
    corners = plane.origin + np.array([[0, 0], [w, 0], [w, h], [0, h], [0, 0]]) @ \
        plane.rotation[:, :2].T
    stream.log("robot/board", rr.LineStrips3D([corners], colors=[(150, 150, 150)]),
               static=True)
    # pen tip and the ink so far at each pose time
    step_of_pose = np.clip(np.searchsorted(sim.t, sim.pose_t), 0, len(sim.t) - 1)
    stream.send_columns("robot/pen_tip", indexes=[times], columns=rr.Points3D.columns(
        positions=sim.tip[step_of_pose], radii=np.full(len(step_of_pose), 0.003)))
    touched = np.flatnonzero(sim.contact)
    if touched.size == 0:
        return
    keep = touched[:: max(1, touched.size // max_trace_points)]
    for j, step in enumerate(step_of_pose):
        if j % 3 and j != len(step_of_pose) - 1:
            continue  # the trace grows ten times a second at 30 poses/s
        upto = keep[keep <= step]
        if upto.size == 0:
            continue
        stream.set_time("time", duration=float(sim.pose_t[j]))
        stream.log("robot/contact_trace", rr.Points3D(sim.contact_pos[upto],
                                                      colors=[(20, 20, 20)], radii=[0.0008]))


def log_arm_execution(stream: Any, program: Any, t: np.ndarray, q: np.ndarray,
                      tip: np.ndarray, rate: float = 30.0) -> None:
    """Log a real arm's reported joint positions q (N, 7) at robot times t (N,) and its pen
    tips (N, 3) into ``stream``, ``rate`` poses per second (module docstring)."""
    import pinocchio as pin
    import rerun as rr

    from inkmotion.robot.kinematics import pen_model

    cart, setup = program.cartesian, program.setup
    stream.log("robot", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    strips = [cart.position[a:b] for a, b in _runs(cart.pen_down) if b - a >= 2]
    if strips:
        stream.log("robot/planned_path", rr.LineStrips3D(strips, colors=[(80, 80, 220)],
                                                          radii=[0.0006]), static=True)
    plane = setup.plane
    w, h = setup.paper
    corners = plane.origin + np.array([[0, 0], [w, 0], [w, h], [0, h], [0, 0]]) @ \
        plane.rotation[:, :2].T
    stream.log("robot/board", rr.LineStrips3D([corners], colors=[(150, 150, 150)]),
               static=True)
    pen = pen_model(setup.pen_length)
    data = pen.model.createData()
    gap = (tip - plane.origin) @ plane.normal
    drawn = np.flatnonzero(gap <= 0.001)
    step = max(1, int(round(1.0 / (rate * max(np.median(np.diff(t)), 1e-6))))) if len(t) > 1 \
        else 1
    for i in range(0, len(t), step):
        pin.forwardKinematics(pen.model, data, q[i])
        pin.updateFramePlacements(pen.model, data)
        chain = [data.oMi[j].translation for j in range(1, pen.model.njoints)]
        chain.append(data.oMf[pen.frame].translation)
        stream.set_time("time", duration=float(t[i]))
        stream.log("robot/arm", rr.LineStrips3D([np.array(chain)], colors=[(230, 120, 30)],
                                                radii=[0.01]))
        stream.log("robot/pen_tip", rr.Points3D([tip[i]], radii=[0.003]))
        upto = drawn[drawn <= i]
        if upto.size:
            keep = upto[:: max(1, upto.size // 2000)]
            stream.log("robot/trace", rr.Points3D(tip[keep], colors=[(20, 20, 20)],
                                                  radii=[0.0008]))
