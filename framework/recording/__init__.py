"""rerun recordings of runs: the :class:`RerunRecorder` observer and readers of .rrd files.

The recorder and readers load on first use (PEP 562): ``inkmotion view`` needs only
:data:`RECORDING_NAME` and must not import torch or rerun to find a file.
"""

from __future__ import annotations

import importlib
from typing import Any

#: file name of a job's recording among its artifacts
RECORDING_NAME = "recording.rrd"

_LAZY = {
    "RerunRecorder": "inkmotion.recording.recorder",
    "entity_paths": "inkmotion.recording.reader",
    "read_step_count": "inkmotion.recording.reader",
    "read_steps": "inkmotion.recording.reader",
}

__all__ = ["RECORDING_NAME", "RerunRecorder", "entity_paths", "read_step_count", "read_steps"]


def __getattr__(name: str) -> Any:
    """Import the recorder or the readers on first access (PEP 562) and cache the name."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'inkmotion.recording' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The public names, loaded or not, beside what the module already holds."""
    return sorted(set(globals()) | set(__all__))
