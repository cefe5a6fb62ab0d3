"""inkmotion: human-like sigma-lognormal drawing motions, fitted through a differentiable
renderer, for artists, roboticists and researchers.

Public API (kept small)::

    inkmotion.MotorPlan             .load(path) / .save(path) / .end_time
    inkmotion.kinematics(plan, t)   -> positions, velocities, accelerations at times t
    inkmotion.bezier_segments(plan, n=None) -> (S, 4, D) control points
    inkmotion.plugin(kind, name)    -> the registered plugin object

The names load on first use (PEP 562), so importing a submodule — the command line, the
job store — does not import torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inkmotion.lazy import lazy_names

if TYPE_CHECKING:  # what type checkers and IDEs see; at run time __getattr__ loads them
    from inkmotion.geometry.bezier import bezier_segments
    from inkmotion.plugin_host.manager import plugin
    from inkmotion.sigma_lognormal.kinematics import kinematics
    from inkmotion.sigma_lognormal.plan import Drawing, MotorPlan

__version__ = "0.1.0"

#: public name -> the module that defines it
_PUBLIC = {
    "Drawing": "inkmotion.sigma_lognormal.plan",
    "MotorPlan": "inkmotion.sigma_lognormal.plan",
    "bezier_segments": "inkmotion.geometry.bezier",
    "kinematics": "inkmotion.sigma_lognormal.kinematics",
    "plugin": "inkmotion.plugin_host.manager",
}

__all__ = ["Drawing", "MotorPlan", "__version__", "bezier_segments", "kinematics", "plugin"]

__getattr__, __dir__ = lazy_names(__name__, _PUBLIC, globals(), __all__)
