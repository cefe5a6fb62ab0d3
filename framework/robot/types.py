"""The data that flows between the robot stages: calibrated setup → timed Cartesian
trajectory → joint trajectory → execution. Plain NumPy arrays in SI units (m, s, rad), all
in the robot's base frame."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class CartesianTrajectory:
    """The pen tip's planned path, sampled uniformly at the control rate.

    ``pen_down[k]`` is True while drawing; ``stroke[k]`` is the plan path index drawn at
    sample k (−1 during pen-up transfers and the approach/retreat from home). ``normal``
    is the drawing plane's unit normal pointing away from the board (the pen points along
    −normal). Starts and ends at rest.
    """

    t: np.ndarray  # (N,) s, t[k] = k / rate
    position: np.ndarray  # (N, 3) m, base frame
    pen_down: np.ndarray  # (N,) bool
    stroke: np.ndarray  # (N,) int
    normal: np.ndarray  # (3,)
    rate: float  # Hz
    time_scale: float = 1.0  # k: plan time × k = robot time (uniform scaling)
    info: dict = field(default_factory=dict)  # figures of the timing (peaks, limits, ...)
    #: (N, 3) unit: the pen points along −axis[k] at sample k, where that is not −normal
    #: throughout (the first and last moves turn the pen between home's axis and the
    #: plane's: inkmotion.robot.timing); None: −normal at every sample
    axis: np.ndarray | None = None

    def pen_normals(self) -> np.ndarray:
        """(N, 3) unit: the pen points along −pen_normals()[k] at sample k."""
        if self.axis is not None:
            return self.axis
        n = np.asarray(self.normal, dtype=float)
        return np.repeat((n / np.linalg.norm(n))[None], len(self.t), axis=0)


@dataclass
class JointTrajectory:
    """Joint positions of the arm (7 joints, fingers excluded) at the control rate, with
    the tracking quality of the pen tip under forward kinematics."""

    t: np.ndarray  # (N,) s
    q: np.ndarray  # (N, 7) rad
    rate: float  # Hz
    max_position_error: float  # m, pen tip vs the Cartesian trajectory
    max_orientation_error: float  # rad, pen axis vs −normal
    info: dict = field(default_factory=dict)  # solver figures (iterations, time, ...)


@dataclass
class RobotProgram:
    """Everything a robot backend needs: the setup as used, the plan it came from, the
    timed pen-tip path and the joint trajectory that follows it (all base frame, SI)."""

    setup: Any  # inkmotion.robot.setup.RobotSetup
    mapping: Any  # inkmotion.robot.calibration.PaperMapping: canvas px -> plane m
    canvas: tuple[float, float]  # (W, H) px of the plan
    cartesian: CartesianTrajectory
    joints: JointTrajectory
    info: dict = field(default_factory=dict)  # planning figures (times, limits, ...)
    drawing: Any = None  # the inkmotion.sigma_lognormal.Drawing the program draws
