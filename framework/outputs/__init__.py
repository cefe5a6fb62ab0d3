"""Output writers: SVG, PNG and overlay images, speed plot, trajectory CSV, atomic files,
and the command line's refusal to write over results (:func:`refuse_to_overwrite`).

The writers load on first use (PEP 562): :class:`StagingDir` is needed by code that must
not import torch (the gallery), the image writers import it.
"""

from __future__ import annotations

from inkmotion.lazy import lazy_names
from inkmotion.outputs.atomic import StagingDir

_LAZY = {
    "OutputExistsError": "inkmotion.outputs.overwrite",
    "refuse_to_overwrite": "inkmotion.outputs.overwrite",
    "write_overlay": "inkmotion.outputs.images",
    "write_png": "inkmotion.outputs.images",
    "write_speed_plot": "inkmotion.outputs.speed_plot",
    "write_svg": "inkmotion.outputs.svg",
    "write_trajectory_csv": "inkmotion.outputs.trajectory_csv",
}

__all__ = [
    "OutputExistsError",
    "StagingDir",
    "refuse_to_overwrite",
    "write_overlay",
    "write_png",
    "write_speed_plot",
    "write_svg",
    "write_trajectory_csv",
]

__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals(), __all__)
