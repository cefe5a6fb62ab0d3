"""The execution replayed in the job's rerun recording, on a ``time`` timeline (seconds):

``robot/links/<body>``      the Panda's collision meshes (Asset3D, static) moved by a
                            Transform3D per recorded pose (send_columns: one chunk per link)
``robot/board``             the board's top face, a static box outline
``robot/planned_path``      the planned pen-tip path while drawing (static LineStrips3D)
``robot/pen_tip``           the simulated pen tip at each recorded pose
``robot/contact_trace``     the ink laid so far: the contact points up to each recorded pose

So ``inkmotion view`` shows the arm drawing; the step timeline holds the planning stages.
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
