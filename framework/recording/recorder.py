"""A rerun recording of every optimisation step (``recording.rrd`` among the artifacts).

Layout of the recording (one entity path per stroke, as the rerun examples do):

======================================  ==================================================
``target`` (static)                     the target image (paper white, ink black)
``input/traces`` (static)               the input polylines, LineStrips2D
``losses/<name>``, ``t_end``            Scalars on the ``step`` timeline, every step
``rendered``                            the rendered image, every ``image_every`` steps
``strokes/<p>/trajectory``              the sampled trajectory of path p, LineStrips2D
``strokes/<p>/targets``                 its virtual targets, Points2D (for a 3-D plan
                                        sized by their stroke radius in px)
``speed/<p>``                           its speed profile: (t, −|v|) as a LineStrips2D
======================================  ==================================================

The recorder owns a private :class:`rerun.RecordingStream` (no global rerun state), saved
to a file in the job's staging directory, and asks the runner for images and geometry only
on the steps it logs them (``wants_image`` / ``wants_geometry``), so the optimiser builds no
heavy data it does not need. Per-step scalars and geometry are buffered and sent as
columns (``send_columns``) every ``flush_every`` steps: one native call per entity per
flush instead of one per step keeps the recorder well under 10 % of a step.

3-D (2.5D) plans log their x, y like 2-D ones; the radius of a virtual target becomes the
radius of its dot (rerun's LineStrips2D has one radius per strip, not per vertex, so the
trajectory keeps its default line).
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from inkmotion.events import RunContext, StepState
from inkmotion.recording import RECORDING_NAME  # noqa: E402, F401 - re-exported

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


def _flat(tensors: list[torch.Tensor], dims: int) -> tuple[np.ndarray, list[int]]:
    """Concatenate per-path tensors into one numpy copy: ((N, dims) or (N,), offsets)."""
    if not tensors:
        return np.zeros((0, dims) if dims else (0,), dtype=np.float32), []
    flat = torch.cat([t.detach() for t in tensors])
    if dims:
        flat = flat[:, :dims]
    offsets = np.cumsum([0] + [len(t) for t in tensors]).tolist()
    return flat.float().cpu().numpy().copy(), offsets


def _numbers(values: list) -> np.ndarray:
    """Floats from a list of 0-d tensors (one device read) or numbers."""
    if values and isinstance(values[0], torch.Tensor):
        return torch.stack([v.reshape(()).double() for v in values]).cpu().numpy()
    return np.asarray(values, dtype=np.float64)


@dataclass
class _StepGeometry:
    """One step's trajectories, speeds and virtual targets, flat, with per-path offsets."""

    step: int
    t_end: float
    positions: tuple[np.ndarray, list[int]]
    speeds: tuple[np.ndarray, list[int]]
    targets: tuple[np.ndarray, list[int]]
    target_radii: tuple[np.ndarray, list[int]] | None = None  # 3-D plans: (N,) px

    def cut(self, what: str, p: int) -> np.ndarray:
        data, offsets = getattr(self, what)
        return data[offsets[p]:offsets[p + 1]]

    def count(self, what: str) -> int:
        """Number of paths with data of kind ``what``."""
        return max(len(getattr(self, what)[1]) - 1, 0)

    def same_layout(self, other: _StepGeometry) -> bool:
        return (self.positions[1] == other.positions[1] and self.speeds[1] == other.speeds[1]
                and self.targets[1] == other.targets[1]
                and (self.target_radii is None) == (other.target_radii is None))


def _add(buffer: dict[str, tuple[list[int], list]], entity: str, step: int,
         value: Any) -> None:
    steps, values = buffer.setdefault(entity, ([], []))
    steps.append(step)
    values.append(value)


class RerunRecorder:
    """Observer writing a rerun recording of a run.

    ``path``: the .rrd file; ``None`` writes ``recording.rrd`` into the run's staging
    directory, so it moves into the artifacts with the rest. ``image_every``: log the
    rendered image every k steps (0: never; the first and last steps are always logged
    when k > 0). ``geometry_every``: the same for trajectories, targets and speed.
    """

    def __init__(self, path: str | Path | None = None, image_every: int = 10,
                 geometry_every: int = 1, recording_id: str | None = None,
                 flush_every: int = 50) -> None:
        self.path = Path(path) if path is not None else None
        self.image_every = max(0, int(image_every))
        self.geometry_every = max(0, int(geometry_every))
        self.recording_id = recording_id or uuid.uuid4().hex
        self.flush_every = max(1, int(flush_every))
        self._rec: Any = None
        self._total = 0
        self._paths_logged = 0
        self._pending = 0  # steps buffered since the last flush
        self._scalars: dict[str, tuple[list[int], list[float]]] = {}  # entity -> steps, values
        self._geometry: list[_StepGeometry] = []

    @property
    def stream(self) -> Any:
        """The open rerun RecordingStream (None before ``on_start`` or after ``close``):
        a job kind may log its own entities into the same recording (e.g. a simulation's
        replay on a time timeline)."""
        return self._rec

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
        self._total = int(ctx.total_steps)
        rec = rr.RecordingStream(APPLICATION_ID, recording_id=self.recording_id)
        rec.save(str(self.path))
        self._rec = rec
        label = getattr(ctx.spec, "label", "")
        rec.send_recording_name(f"{getattr(ctx.spec, 'kind', 'job')} {label}".strip())
        if ctx.target is not None:
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
        step = int(state.step)
        for name, value in state.losses.items():  # 0-d tensors: read at flush, in one go
            _add(self._scalars, f"losses/{name}", step, value)
        if state.t_end is not None:  # a kind that optimises no motion has none
            _add(self._scalars, "t_end", step, state.t_end)
        if state.rendered is not None:
            rec.set_time("step", sequence=step)
            rec.log("rendered", rr.Image(_paper(state.rendered)))
        if state.positions:
            self._add_geometry(step, state)
        self._pending += 1
        if self._pending >= self.flush_every:
            self.flush()

    def _add_geometry(self, step: int, state: StepState) -> None:
        """Buffer one step's geometry as three flat arrays (one copy each, no per-path
        work here); :meth:`flush` cuts them per stroke."""
        n_paths = len(state.positions)
        if n_paths < self._paths_logged:  # a path disappeared: clear it
            import rerun as rr

            self.flush()
            self._rec.set_time("step", sequence=step)
            for p in range(n_paths, self._paths_logged):
                self._rec.log(f"strokes/{p}", rr.Clear(recursive=True))
                self._rec.log(f"speed/{p}", rr.Clear(recursive=True))
        self._paths_logged = n_paths
        radii = None
        if state.targets and state.targets[0].shape[-1] == 3:  # (n, 3): x, y, r
            radii = _flat([t[:, 2] for t in state.targets], 0)
        self._geometry.append(_StepGeometry(
            step=step, t_end=float(state.t_end),  # geometry steps read the device anyway
            positions=_flat(state.positions, 2), speeds=_flat(state.speeds, 0),
            targets=_flat(state.targets, 2), target_radii=radii))

    def flush(self) -> None:
        """Send the buffered steps as columns (one call per entity)."""
        import rerun as rr

        rec = self._rec
        self._pending = 0
        if rec is None:
            return
        for entity, (steps, values) in self._scalars.items():
            rec.send_columns(entity, indexes=[rr.TimeColumn("step", sequence=steps)],
                             columns=rr.Scalars.columns(scalars=_numbers(values)))
        self._scalars.clear()
        self._send_geometry()

    def _send_geometry(self) -> None:
        import rerun as rr

        rec, buffered = self._rec, self._geometry
        self._geometry = []
        if not buffered:
            return
        # group consecutive steps with the same layout (paths and sizes do not change
        # within a fit, so this is one group)
        groups: list[list[_StepGeometry]] = []
        for g in buffered:
            if groups and g.same_layout(groups[-1][0]):
                groups[-1].append(g)
            else:
                groups.append([g])
        for group in groups:
            steps = rr.TimeColumn("step", sequence=[g.step for g in group])
            first = group[0]
            ones = [1] * len(group)
            for p in range(first.count("positions")):
                # (k, n, 2): one strip per step, the numpy fast path of LineStrips2D
                strips = np.stack([g.cut("positions", p) for g in group])
                rec.send_columns(f"strokes/{p}/trajectory", indexes=[steps],
                                 columns=rr.LineStrips2D.columns(strips=strips)
                                 .partition(lengths=ones))
                if p < first.count("targets"):
                    pts = [g.cut("targets", p) for g in group]
                    radii = None if first.target_radii is None else np.concatenate(
                        [g.cut("target_radii", p) for g in group])
                    cols = rr.Points2D.columns(positions=np.concatenate(pts), radii=radii)
                    rec.send_columns(f"strokes/{p}/targets", indexes=[steps],
                                     columns=cols.partition(lengths=[len(x) for x in pts]))
                if p < first.count("speeds"):
                    speed = np.stack([g.cut("speeds", p) for g in group])  # (k, n)
                    frac = np.linspace(0.0, 100.0, speed.shape[1], dtype=np.float32)
                    t = frac[None, :] * np.array([g.t_end for g in group],
                                                 dtype=np.float32)[:, None]
                    curves = np.stack((t, -speed), axis=2)  # (k, n, 2)
                    rec.send_columns(f"speed/{p}", indexes=[steps],
                                     columns=rr.LineStrips2D.columns(strips=curves)
                                     .partition(lengths=ones))

    def on_end(self, report: dict) -> None:
        """Flush the recording so the file is complete before the artifacts move."""
        self.close()

    def close(self) -> None:
        """Flush and detach the file sink (idempotent; call it when a run fails too)."""
        if self._rec is not None:
            self.flush()
        rec, self._rec = self._rec, None
        if rec is not None:
            rec.flush()
            rec.disconnect()
