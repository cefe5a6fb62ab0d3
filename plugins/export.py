"""Robot backend "export": the joint and Cartesian trajectories for a real controller at a
chosen rate, as CSV and JSON with the setup, the limits and the calibration in the header.
Implementation: :mod:`inkmotion.robot.export`; importing this module imports no NumPy."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import RobotBackend


@dataclass
class ExportOptions:
    """Options of the 'export' backend."""

    rate: float = param(1000.0, "Samples per second of the exported trajectories, Hz.",
                        minimum=1, maximum=10_000)


class Export:
    """Write a robot program for a real controller (see the module docstring)."""

    name = "export"
    description = "Joint + Cartesian trajectories for a real controller: CSV and JSON, any rate."
    Options = ExportOptions

    def execute(self, program: Any, folder: Path, **options: Any) -> dict:
        from inkmotion.robot.export import export_program

        return export_program(program, Path(folder), **options)


@hookimpl
def inkmotion_robot_backends() -> list[RobotBackend]:
    return [Export()]
