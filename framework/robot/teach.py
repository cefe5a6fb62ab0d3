"""Teaching the drawing plane on the robot: the user guides the pen tip onto the four
corners of the drawing area, one Enter each, and the corners become a setup file.

While teaching, the arm is held by franky's joint impedance tracker with a very low
stiffness (``GUIDING_STIFFNESS``) whose target follows the measured pose every cycle: the
arm floats under gravity compensation and goes where a hand pushes it (franky's manual
guidance example; the robot's own guiding mode, the pilot buttons, works too, but not every
FCI server offers it). Each corner is the pen tip by forward kinematics of the measured
joints (Pinocchio, the pen ``pen_length`` m along the flange's z axis). The corners are then
checked as any setup's: planar within the tolerance, a rectangle that holds the paper.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from inkmotion.errors import InputError, RobotError
from inkmotion.robot.kinematics import pen_model, pen_poses
from inkmotion.robot.setup import RobotSetup, load_setup, parse_setup, setup_to_toml

#: N·m/rad: the floating arm's stiffness while it is guided
GUIDING_STIFFNESS = 6.0
CORNERS = ("first (the paper's bottom-left, as it will be read)", "second (bottom-right)",
           "third (top-right)", "fourth (top-left)")


def teach_corners(robot: Any, pen_length: float, wait_for_corner: Callable[[int], None]
                  ) -> np.ndarray:
    """The four corners (4, 3) m in the base frame: the arm floats (module docstring)
    while ``wait_for_corner(i)`` (i = 0..3, run in a helper thread) waits for the user,
    and the pen tip is read when it returns."""
    import franky

    pen = pen_model(float(pen_length))
    corners = np.zeros((4, 3))
    done = threading.Event()
    problem: list[BaseException] = []
    index = [0]

    def ask() -> None:
        try:
            for i in range(4):
                wait_for_corner(i)
                index[0] = i + 1
                q = np.asarray(robot.current_joint_positions, dtype=float)
                corners[i] = pen_poses(pen, q[None])[0][0]
        except BaseException as exc:  # noqa: BLE001 - re-raised in the caller's thread
            problem.append(exc)
        finally:
            done.set()

    asker = threading.Thread(target=ask, name="teach corners", daemon=True)
    try:
        with franky.JointImpedanceTracker(robot, stiffness=[GUIDING_STIFFNESS] * 7,
                                          period=0.001) as tracker:
            asker.start()
            while not done.is_set() and tracker.tick() is not None:
                tracker.set_target(robot.current_joint_positions, dq=[0.0] * 7,
                                   tau_ff=[0.0] * 7)
    except franky.Exception as exc:
        raise RobotError(f"The robot stopped while being guided ({exc}); clear its errors "
                         "in Desk and teach again.") from exc
    if problem:
        raise problem[0]
    if index[0] < 4:
        raise RobotError("The robot left guiding before the four corners were taught; "
                         "teach again.")
    return corners


def taught_setup(corners: np.ndarray, base: str | Path | None = None) -> RobotSetup:
    """The setup ``base`` (default: the shipped one) with its plane taught at ``corners``
    (4, 3) m and the paper shrunk to the taught rectangle where it would not fit; checked
    as any setup file (InputError naming what is wrong)."""
    setup = load_setup(base)
    points = np.asarray(corners, dtype=float)
    width = float(np.linalg.norm(points[1] - points[0]))
    height = float(np.linalg.norm(points[3] - points[0]))
    paper = (min(setup.paper[0], np.floor(width * 1e3) / 1e3),
             min(setup.paper[1], np.floor(height * 1e3) / 1e3))
    if min(paper) <= 2 * setup.margin:
        raise InputError(f"The taught corners span {width:.3f} × {height:.3f} m, too small "
                         f"for paper with a {setup.margin} m margin; teach the corners of the "
                         "drawing area again, in order around it.")
    draft = dataclasses.replace(setup, plane_points=points, paper=paper)
    return parse_setup(setup_to_toml(draft), "the taught setup")
