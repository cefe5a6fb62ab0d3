"""A robot program from a drawing: the drawing timed on the setup's paper, the joint
trajectory that draws it, then that trajectory retimed where it would exceed the arm's
joint limits (the engine behind the 'simulate' and 'draw' kinds).

Everything that can refuse the drawing (reachability of every sample) runs before the
joint trajectory is solved in full, so an unreachable drawing costs a timing, not a solve.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from inkmotion.robot.types import RobotProgram

if TYPE_CHECKING:
    from inkmotion.robot.limits import ArmLimits
    from inkmotion.robot.setup import RobotSetup
    from inkmotion.sigma_lognormal import Drawing


def plan_program(drawing: Drawing, setup: RobotSetup,
                 on_stage: Callable[[int, str], None] | None = None,
                 arm: ArmLimits | None = None) -> RobotProgram:
    """Time the drawing on the setup, solve its joint trajectory inside ``arm``'s position
    ranges (default: the Panda's) and retime it so that every joint stays within the
    setup's ``limit_fraction`` of the arm's velocity, acceleration and jerk limits
    (:mod:`inkmotion.robot.retime`; raises InputError with one sentence for an unreachable
    drawing, before any joint trajectory is solved); ``on_stage(1, "timing")`` and
    ``on_stage(2, "joints")`` report the two stages."""
    from inkmotion.robot.calibration import PaperMapping
    from inkmotion.robot.joints import solve_joint_trajectory
    from inkmotion.robot.kinematics import check_reachable, pen_model, pen_poses
    from inkmotion.robot.limits import PANDA
    from inkmotion.robot.retime import fit_to_limits
    from inkmotion.robot.timing import time_drawing

    t0 = time.perf_counter()
    mapping = PaperMapping.from_canvas(drawing.canvas, setup.paper, setup.margin)
    home_tip, home_axis = pen_poses(pen_model(setup.pen_length), setup.home[None])
    _check_home_above_board(home_tip[0], setup)
    cartesian = time_drawing(drawing, setup, start=home_tip[0], mapping=mapping,
                             start_normal=-home_axis[0])
    check_reachable(cartesian.position, cartesian.pen_normals(), setup.pen_length,
                    joint_margin=setup.joint_margin, stroke=cartesian.stroke)
    timing_s = time.perf_counter() - t0
    if on_stage is not None:
        on_stage(1, "timing")
    t1 = time.perf_counter()
    arm = arm or PANDA
    joints = solve_joint_trajectory(cartesian, pen_length=setup.pen_length, home=setup.home,
                                    joint_margin=setup.joint_margin, q_start=setup.home,
                                    position_limits=(arm.lower, arm.upper))
    cartesian, joints, limits_info = fit_to_limits(
        cartesian, joints, arm, fraction=setup.limit_fraction,
        position_margin=0.5 * setup.joint_margin)
    joints_s = time.perf_counter() - t1
    if on_stage is not None:
        on_stage(2, "joints")
    info = {"timing_s": round(timing_s, 3), "joints_s": round(joints_s, 3),
            "planning_s": round(timing_s + joints_s, 3), "limits": limits_info}
    return RobotProgram(setup, mapping, drawing.canvas, cartesian, joints, info, drawing)


#: m: the home pose's pen tip must be at least this far above the board (on the robot's
#: side of its plane): the first and last moves run straight between it and pen-up height
HOME_CLEARANCE = 0.005


def _check_home_above_board(tip: np.ndarray, setup: RobotSetup) -> None:
    """Refuse a setup whose home pen tip is not above the board: the straight move from
    home to the first stroke (and back) would pass through the board (it was drawn through,
    with 69 N, 10 mm off the plan, and a report of "done")."""
    from inkmotion.errors import InputError

    gap = float(setup.plane.to_plane(tip)[1][0])
    if gap >= HOME_CLEARANCE:
        return
    where = (f"{-gap * 1e3:.0f} mm below the board" if gap < 0 else
             f"only {gap * 1e3:.1f} mm above the board")
    raise InputError(f"The home pose's pen tip is {where} ([plane] points), so the move to "
                     "the first stroke would pass through it; teach a home pose "
                     f"at least {HOME_CLEARANCE * 1e3:.0f} mm above the board, or lower the "
                     "board.")
