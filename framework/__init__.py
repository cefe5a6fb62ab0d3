"""inkmotion: human-like sigma-lognormal drawing motions, fitted through a differentiable
renderer, for artists, roboticists and researchers.

Public API (kept small)::

    inkmotion.MotorPlan             .load(path) / .save(path) / .end_time
    inkmotion.kinematics(plan, t)   -> positions, velocities, accelerations at times t
    inkmotion.bezier_segments(plan, n=None) -> (S, 4, D) control points
    inkmotion.plugin(kind, name)    -> the registered plugin object
"""

from inkmotion.geometry.bezier import bezier_segments
from inkmotion.plugin_host import plugin
from inkmotion.sigma_lognormal import Drawing, MotorPlan
from inkmotion.sigma_lognormal.kinematics import kinematics

__version__ = "0.1.0"

__all__ = ["Drawing", "MotorPlan", "__version__", "bezier_segments", "kinematics", "plugin"]
