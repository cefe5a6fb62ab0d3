"""A rerun recording of every optimisation step (``recording.rrd`` among the artifacts).

Layout of the recording (one entity path per stroke, as the rerun examples do):

======================================  ==================================================
``target`` (static)                     the target image (paper white, ink black)
``input/traces`` (static)               the input polylines, LineStrips2D
``losses/<name>``, ``t_end``            Scalars on the ``step`` timeline, every step
``rendered``                            the rendered image, every ``image_every`` steps
``strokes/<p>/trajectory``              the sampled trajectory of path p, LineStrips2D
``strokes/<p>/targets``                 its virtual targets, Points2D
``speed/<p>``                           its speed profile: (t, −|v|) as a LineStrips2D
======================================  ==================================================

The recorder owns a private :class:`rerun.RecordingStream` (no global rerun state), saved
to a file in the job's staging directory, and asks the runner for images and geometry only
on the steps it logs them (``wants_image`` / ``wants_geometry``), so the optimiser builds no
heavy data it does not need.
"""

from __future__ import annotations

import uuid
from pathlib import Path
from typing import Any

import numpy as np
import torch

from inkmotion.jobs.observers import RunContext, StepState

RECORDING_NAME = "recording.rrd"
APPLICATION_ID = "inkmotion"


def _paper(image: torch.Tensor) -> np.ndarray:
    """(H, W) ink-coverage tensor in [0, 1] -> uint8 image, white paper and black ink."""
    ink = np.asarray(image.detach().cpu().numpy(), dtype=np.float32)
    out = np.empty(ink.shape, dtype=np.uint8)
    np.clip(255.5 - 255.0 * ink, 0.0, 255.0, out=out, casting="unsafe")
    return out


def _xy(points: Any) -> np.ndarray:
    """First two coordinates of (n, D) points as float32 numpy (drops the radius)."""
    if isinstance(points, torch.Tensor):
        points = points.detach().cpu().numpy()
    return np.ascontiguousarray(np.asarray(points, dtype=np.float32)[:, :2])


class RerunRecorder:
    """Observer writing a rerun recording of a run.

    ``path``: the .rrd file; ``None`` writes ``recording.rrd`` into the run's staging
    directory, so it moves into the artifacts with the rest. ``image_every``: log the
    rendered image every k steps (0: never; the first and last steps are always logged
    when k > 0). ``geometry_every``: the same for trajectories, targets and speed.
    """

    def __init__(self, path: str | Path | None = None, image_every: int = 10,
                 geometry_every: int = 1, recording_id: str | None = None) -> None:
        self.path = Path(path) if path is not None else None
        self.image_every = max(0, int(image_every))
        self.geometry_every = max(0, int(geometry_every))
        self.recording_id = recording_id or uuid.uuid4().hex
        self._rec: Any = None
        self._total = 0
        self._paths_logged = 0

    # -- what the runner should build -----------------------------------------------------
    def _every(self, k: int, step: int) -> bool:
        return k > 0 and (step % k == 0 or step == 1 or step == self._total)

    def wants_image(self, step: int) -> bool:
        return self._rec is not None and self._every(self.image_every, step)

    def wants_geometry(self, step: int) -> bool:
        return self._rec is not None and self._every(self.geometry_every, step)

    # -- observer protocol ------------------------------------------------------------------
    def on_start(self, ctx: RunContext) -> None:
        import rerun as rr

        if self.path is None:
            self.path = Path(ctx.staging_dir) / RECORDING_NAME
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._total = int(getattr(ctx.spec.params, "steps", 0) or 0)
        rec = rr.RecordingStream(APPLICATION_ID, recording_id=self.recording_id)
        rec.save(str(self.path))
        self._rec = rec
        label = getattr(ctx.spec, "input", "")
        rec.send_recording_name(f"{getattr(ctx.spec, 'kind', 'job')} {label}".strip())
        rec.log("target", rr.Image(_paper(ctx.target)), static=True)
        strips = [_xy(s) for s in ctx.traces if len(s) >= 2]
        if strips:
            rec.log("input/traces", rr.LineStrips2D(strips, colors=[(120, 120, 120)]),
                    static=True)

    def on_step(self, state: StepState) -> None:
        import rerun as rr

        rec = self._rec
        if rec is None:
            return
        rec.set_time("step", sequence=int(state.step))
        for name, value in state.losses.items():
            rec.log(f"losses/{name}", rr.Scalars(float(value)))
        rec.log("t_end", rr.Scalars(float(state.t_end)))
        if state.rendered is not None:
            rec.log("rendered", rr.Image(_paper(state.rendered)))
        if state.positions:
            self._log_geometry(state)

    def _log_geometry(self, state: StepState) -> None:
        import rerun as rr

        rec = self._rec
        n_paths = len(state.positions)
        t_end = float(state.t_end)
        for p, pos in enumerate(state.positions):
            rec.log(f"strokes/{p}/trajectory", rr.LineStrips2D([_xy(pos)]))
            if p < len(state.targets):
                rec.log(f"strokes/{p}/targets", rr.Points2D(_xy(state.targets[p]), radii=1.5))
            if p < len(state.speeds):
                speed = state.speeds[p].detach().float().cpu().numpy()
                t = np.linspace(0.0, t_end, len(speed), dtype=np.float32)
                rec.log(f"speed/{p}", rr.LineStrips2D([np.stack((100.0 * t, -speed), 1)]))
        for p in range(n_paths, self._paths_logged):  # a path disappeared: clear it
            rec.log(f"strokes/{p}", rr.Clear(recursive=True))
            rec.log(f"speed/{p}", rr.Clear(recursive=True))
        self._paths_logged = n_paths

    def on_end(self, report: dict) -> None:
        """Flush the recording so the file is complete before the artifacts move."""
        self.close()

    def close(self) -> None:
        """Flush and detach the file sink (idempotent; call it when a run fails too)."""
        rec, self._rec = self._rec, None
        if rec is not None:
            rec.flush()
            rec.disconnect()
