"""rerun recordings of runs: the :class:`RerunRecorder` observer and readers of .rrd files."""

from inkmotion.recording.reader import entity_paths, read_step_count, read_steps
from inkmotion.recording.recorder import RECORDING_NAME, RerunRecorder

__all__ = ["RECORDING_NAME", "RerunRecorder", "entity_paths", "read_step_count", "read_steps"]
