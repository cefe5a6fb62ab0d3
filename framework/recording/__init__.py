"""rerun recordings of runs: the :class:`RerunRecorder` observer and readers of .rrd files.

The recorder and readers load on first use (PEP 562): ``inkmotion view`` needs only
:data:`RECORDING_NAME` and must not import torch or rerun to find a file.
"""

from __future__ import annotations

from inkmotion.lazy import lazy_names

#: file name of a job's recording among its artifacts
RECORDING_NAME = "recording.rrd"

_LAZY = {
    "RerunRecorder": "inkmotion.recording.recorder",
    "entity_paths": "inkmotion.recording.reader",
    "read_step_count": "inkmotion.recording.reader",
    "read_steps": "inkmotion.recording.reader",
}

__all__ = ["RECORDING_NAME", "RerunRecorder", "entity_paths", "read_step_count", "read_steps"]

__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals(), __all__)
