"""Robot backend "franka-sim": the joint trajectory executed by a simulated Franka Panda in
MuJoCo at 1 kHz (joint impedance control with gravity and Coriolis compensation), the pen's
contacts with the board drawn into sim_drawing.png. Implementation:
:mod:`inkmotion.robot.backends`; importing this module imports neither MuJoCo nor torch."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import RobotBackend


@dataclass
class FrankaSimOptions:
    """Options of the 'franka-sim' backend."""

    replay_rate: float = param(30.0, "Arm poses per second in the rerun replay.", minimum=1,
                               maximum=1000)


class FrankaSim:
    """Execute a robot program in MuJoCo (see the module docstring)."""

    name = "franka-sim"
    description = "Simulated Franka Panda (MuJoCo, 1 kHz joint impedance control) draws the plan."
    Options = FrankaSimOptions

    def execute(self, program: Any, folder: Path, **options: Any) -> dict:
        """Run the engine with the 'raster' renderer plugin for plan_drawing.png (looked up
        here: the robot engine does not reach into the plugin host)."""
        from inkmotion.plugin_host import host
        from inkmotion.robot.backends import execute_franka_sim

        renderer = host().get("renderer", "raster")
        return execute_franka_sim(program, Path(folder), renderer, **options)

    def replay(self, program: Any, figures: dict, stream: Any) -> None:
        """Log the execution into the job's rerun recording (a time timeline)."""
        from inkmotion.robot.backends import replay

        replay(program, figures, stream)


@hookimpl
def inkmotion_robot_backends() -> list[RobotBackend]:
    return [FrankaSim()]
