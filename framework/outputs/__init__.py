"""Output writers: SVG, PNG and overlay images, speed plot, trajectory CSV, atomic files."""

from inkmotion.outputs.atomic import StagingDir
from inkmotion.outputs.images import write_overlay, write_png
from inkmotion.outputs.speed_plot import write_speed_plot
from inkmotion.outputs.svg import write_svg
from inkmotion.outputs.trajectory_csv import write_trajectory_csv

__all__ = [
    "StagingDir",
    "write_overlay",
    "write_png",
    "write_speed_plot",
    "write_svg",
    "write_trajectory_csv",
]
