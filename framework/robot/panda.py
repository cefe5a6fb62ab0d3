"""The Franka Panda model shipped inside the ``example-robot-data`` wheel (URDF + meshes,
no download); its motion limits are in :mod:`inkmotion.robot.limits`.

The wheel installs its robots under ``cmeel.prefix/share/example-robot-data/robots``; the
files are found through the distribution's own file list, so no import of a module named
after the package is needed (version 6 ships data only).
"""

from __future__ import annotations

import functools
from pathlib import Path

from inkmotion.errors import InkmotionError

#: the arm's seven joints (the URDF also has two finger joints)
ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
#: the frame the pen is mounted on (the flange)
FLANGE = "panda_link8"


@functools.cache
def robots_dir() -> Path:
    """``.../share/example-robot-data/robots`` of the installed example-robot-data."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError as exc:
        raise InkmotionError("The Panda model comes from the example-robot-data package, "
                             "which is not installed; pip install example-robot-data.") from exc
    for f in dist.files or []:
        if f.name == "panda.urdf" and "panda_description" in f.parts:
            path = Path(str(dist.locate_file(f))).resolve()
            return path.parents[2]
    raise InkmotionError("example-robot-data is installed without the Panda model; "
                         "reinstall it (pip install --force-reinstall example-robot-data).")


def panda_urdf(collision: bool = False) -> Path:
    """The Panda URDF (``collision``: the variant whose visuals are the collision meshes)."""
    name = "panda_collision.urdf" if collision else "panda.urdf"
    return robots_dir() / "panda_description" / "urdf" / name


def mesh_dir(kind: str = "collision") -> Path:
    """The folder of the Panda's meshes: ``collision`` (STL) or ``visual`` (DAE)."""
    return robots_dir() / "panda_description" / "meshes" / kind
