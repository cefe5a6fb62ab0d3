"""rerun recordings of runs: the :class:`RerunRecorder` observer and readers of .rrd files.

The recorder and readers load on first use (PEP 562): ``inkmotion view`` needs only
:data:`RECORDING_NAME` and must not import torch or rerun to find a file.
"""

from __future__ import annotations

from inkmotion.lazy import lazy_names

#: file name of a job's recording among its artifacts
RECORDING_NAME = "recording.rrd"


def rerun_binary() -> str | None:
    """The ``rerun`` viewer beside this Python (a virtualenv), else on PATH, else None."""
    import shutil
    import sys
    from pathlib import Path

    here = Path(sys.executable).parent / "rerun"
    return str(here) if here.is_file() else shutil.which("rerun")

_LAZY = {
    "RerunRecorder": "inkmotion.recording.recorder",
    "entity_paths": "inkmotion.recording.reader",
    "read_step_count": "inkmotion.recording.reader",
    "read_steps": "inkmotion.recording.reader",
}

__all__ = ["RECORDING_NAME", "RerunRecorder", "entity_paths", "read_step_count", "read_steps",
           "rerun_binary"]

__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals(), __all__)
