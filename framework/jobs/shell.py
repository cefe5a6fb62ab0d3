"""The job shell: what every job kind needs, around the kind's own ``run(job)``.

``inkmotion run KIND`` and the Celery worker task both call :func:`run_job`, so a job
executed in-process and one executed by a worker write the same artifacts. The shell

1. checks the spec against its kind (inputs, parameters, plugins and their options);
2. seeds torch, NumPy and ``random`` with the spec's seed, resolves the device (``auto``:
   CUDA when present) and the thread count;
3. stages the output folder (``DIR.partial-*``) and commits it atomically: a job that
   fails or is interrupted leaves nothing behind;
4. drives the observers: the rerun recording, the progress bar, the store's progress
   (any object with ``on_start`` / ``on_step`` / ``on_end``, see :mod:`inkmotion.events`);
5. writes job.json (the resolved spec, versions, seed: ``run --config`` reproduces it)
   and report.json (the kind's report plus wall time, device and threads).
"""

from __future__ import annotations

import json
import platform
import random
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from inkmotion.events import RunContext, StepState, wants
from inkmotion.jobs.kind import ResolvedJob, resolve
from inkmotion.jobs.params import PluginChoice, options_dict
from inkmotion.jobs.spec import JobSpec


class ObserverGroup:
    """Several observers seen as one (each method optional on each observer)."""

    def __init__(self, observers: Sequence[object]) -> None:
        self.observers = list(observers)

    def _call(self, method: str, *args: Any) -> None:
        for o in self.observers:
            fn = getattr(o, method, None)
            if fn is not None:
                fn(*args)

    def on_start(self, ctx: RunContext) -> None:
        self._call("on_start", ctx)

    def on_step(self, state: StepState) -> None:
        self._call("on_step", state)

    def on_end(self, report: dict) -> None:
        self._call("on_end", report)

    def close(self) -> None:
        self._call("close")

    def wants_image(self, step: int) -> bool:
        return any(wants(o, "image", step) for o in self.observers)

    def wants_geometry(self, step: int) -> bool:
        return any(wants(o, "geometry", step) for o in self.observers)


@dataclass
class Job:
    """What a job kind's ``run`` receives: its parameters, device, folder and observers."""

    spec: JobSpec
    params: Any  # the kind's Params instance
    device: Any  # torch.device
    folder: Path  # the staging folder: write artifacts here
    observers: ObserverGroup
    resolved: ResolvedJob
    total_steps: int
    started: float = field(default_factory=time.perf_counter)
    #: the job's :class:`~inkmotion.jobs.checkpoint.Checkpoints` (None: not checkpointed);
    #: a job kind that supports it saves its state there and resumes from it
    checkpoints: Any = None

    def plugin(self, choice: PluginChoice) -> Any:
        """The plugin object a parameter chose."""
        return self.resolved.plugin(choice)

    def options(self, choice: PluginChoice) -> dict[str, Any]:
        """That plugin's options from the spec, as keyword arguments."""
        return options_dict(self.resolved.options_of(choice))

    def recording_stream(self) -> Any:
        """The job's open rerun RecordingStream when it is recorded, else None."""
        for o in self.observers.observers:
            stream = getattr(o, "stream", None)
            if stream is not None:
                return stream
        return None

    def start(self, canvas: tuple[int, int] = (0, 0), target: Any = None,
              traces: list | None = None) -> None:
        """Tell the observers the job has started (call before the first step)."""
        self.observers.on_start(RunContext(self.spec, self.folder, self.total_steps, canvas,
                                           target, list(traces or [])))


def versions() -> dict[str, str]:
    import numpy as np
    import torch

    import inkmotion

    return {"inkmotion": inkmotion.__version__, "torch": torch.__version__,
            "numpy": np.__version__, "python": platform.python_version()}


def standard_observers(spec: JobSpec, *, record: bool, progress: bool,
                       recording_id: str | None = None) -> list[object]:
    """The rerun recorder (``record``) and the progress bar (``progress``) for ``spec``."""
    observers: list[object] = []
    if record:
        from inkmotion.recording.recorder import RerunRecorder

        observers.append(RerunRecorder(image_every=spec.record_every,
                                       recording_id=recording_id))
    if progress:
        from inkmotion.jobs.progress_bar import ProgressBar

        observers.append(ProgressBar())
    return observers


def run_job(spec: JobSpec, out_dir: str | Path, observers: Sequence[object] = (), *,
            record: bool = False, progress: bool = False,
            recording_id: str | None = None, checkpoint: str | Path | None = None,
            checkpoint_every: int | None = None, checkpoint_s: float | None = None,
            checkpoint_now: Any = None) -> dict:
    """Execute ``spec`` and place its artifacts in ``out_dir`` atomically; return the report.

    ``observers`` are added to the standard ones (``record``: recording.rrd; ``progress``:
    a terminal bar). ``checkpoint``: a file for the job's checkpoints (every
    ``checkpoint_every`` steps or ``checkpoint_s`` seconds), resumed from when it holds
    one of this spec; report.json then says ``resumed_from_step``; ``checkpoint_now`` (a
    ``threading.Event``) asks for a checkpoint at the next step once it is set. Raises
    :class:`inkmotion.errors.InkmotionError` subclasses for user-caused failures (bad
    input, unknown plugin); nothing is left in ``out_dir`` then.
    """
    import numpy as np
    import torch

    from inkmotion.devices import configure_threads, resolve_device
    from inkmotion.outputs import StagingDir

    resolved = resolve(spec)
    device = resolve_device(spec.device)
    threads = configure_threads()
    torch.manual_seed(spec.seed)
    np.random.seed(spec.seed % 2**32)
    random.seed(spec.seed)
    group = ObserverGroup([*standard_observers(spec, record=record, progress=progress,
                                               recording_id=recording_id), *observers])
    total = int(resolved.kind.steps(resolved.params))
    checkpoints = None
    if checkpoint is not None:
        from inkmotion.jobs import checkpoint as ck

        checkpoints = ck.Checkpoints(checkpoint, spec.to_dict(),
                                     checkpoint_every or ck.EVERY_STEPS,
                                     checkpoint_s or ck.EVERY_S, now=checkpoint_now)
    with StagingDir(Path(out_dir)) as staging:
        try:
            job = Job(spec, resolved.params, device, staging.path, group, resolved, total,
                      checkpoints=checkpoints)
            report = dict(resolved.kind.run(job))
            report["kind"] = spec.kind
            report["wall_s"] = round(time.perf_counter() - job.started, 3)
            report["device"] = str(device)
            report["threads"] = threads
            record_job(staging.path, resolved.full_spec(), report)
            group.on_end(report)
        finally:
            group.close()  # files complete (or released) before the folder moves
        staging.commit()
    return report


def record_job(folder: Path, spec: JobSpec, report: dict) -> None:
    """Write job.json (the spec, versions, seed, and the report's ``provenance``: what the
    result was made with beyond the spec, e.g. ``"clip_weights": "random"``) and report.json
    into ``folder``."""
    job = {"spec": spec.to_dict(), "versions": versions(), "seed": spec.seed,
           **report.get("provenance", {})}
    (folder / "job.json").write_text(json.dumps(job, indent=1))
    (folder / "report.json").write_text(json.dumps(report, indent=1))
