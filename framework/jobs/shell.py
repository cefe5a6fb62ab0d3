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

import platform
import random
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from inkmotion.events import RunContext, StepState, wants
from inkmotion.jobs.kind import ResolvedJob, resolve
from inkmotion.jobs.params import PluginChoice, options_dict
from inkmotion.jobs.spec import JobSpec
from inkmotion.json_files import dumps


def _report_of(kind: Any, job: Job) -> dict:
    """The kind's ``run(job)``, held to the JobKind protocol: its report, a dict."""
    report = kind.run(job)
    if not isinstance(report, dict):
        from inkmotion.errors import PluginError

        raise PluginError(f"The job kind {kind.name!r} returned {type(report).__name__} from "
                          f"run(job); it must return its report, a dict (e.g. {{}}).")
    return report


class _RendererWithOptions:
    """A renderer plugin whose calls (and whose ``session``'s) get ``options`` as keyword
    arguments; its other members (``name``, ``renders_canvases``, ...) are the plugin's."""

    def __init__(self, renderer: Any, options: dict[str, Any]) -> None:
        self._renderer, self._options = renderer, options

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self._renderer(*args, **self._options, **kwargs)

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._renderer, name)
        if name != "session":
            return value

        def session(*args: Any, **kwargs: Any) -> Any:
            return value(*args, **self._options, **kwargs)

        return session


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

    def input_file(self, name: str) -> str:
        """The file of input ``name``: a ``sample:NAME`` is the file that ships with
        inkmotion (the spec keeps the name, so job.json reproduces on any installation),
        any other value is the path as given."""
        from inkmotion.samples import locate

        return locate(self.spec.inputs[name])

    def plugin(self, choice: PluginChoice) -> Any:
        """The plugin object a parameter chose."""
        return self.resolved.plugin(choice)

    def options(self, choice: PluginChoice) -> dict[str, Any]:
        """That plugin's options from the spec, as keyword arguments."""
        return options_dict(self.resolved.options_of(choice))

    def renderer(self, choice: PluginChoice) -> Any:
        """The renderer plugin a parameter chose, its options from the spec bound to its
        calls (and to its per-fit ``session``, when it has one): the engines call a
        renderer with the segments alone (the Renderer protocol)."""
        renderer = self.plugin(choice)
        options = self.options(choice)
        return renderer if not options else _RendererWithOptions(renderer, options)

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


def plugin_packages(spec: JobSpec) -> dict[str, str]:
    """The version of each package outside inkmotion whose plugin ``spec`` uses (its job
    kind, or a plugin one of its parameters chose), by distribution name: a result made
    with another package's code says which release of it."""
    from importlib.metadata import PackageNotFoundError, version

    from inkmotion.jobs.kind import job_kind
    from inkmotion.jobs.params import describe
    from inkmotion.plugin_host import host
    from inkmotion.plugin_host.manager import distribution, is_built_in

    kind = job_kind(spec.kind)
    used = [kind]
    for info in describe(kind.Params):
        value = spec.params.get(info.name) if info.plugin_kind is not None else None
        for choice in value if isinstance(value, list) else [value]:
            name = choice.get("name") if isinstance(choice, dict) else choice
            available = host().plugins(info.plugin_kind) if info.plugin_kind else {}
            if isinstance(name, str) and name in available:
                used.append(available[name])
    out: dict[str, str] = {}
    for obj in used:
        if is_built_in(obj):
            continue
        dist = distribution(obj)
        try:
            out[dist] = version(dist)
        except (PackageNotFoundError, ValueError):
            out[dist] = "unknown"
    return dict(sorted(out.items()))


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
            checkpoint_now: Any = None, replace: bool = True) -> dict:
    """Execute ``spec`` and place its artifacts in ``out_dir`` atomically; return the report.

    ``observers`` are added to the standard ones (``record``: recording.rrd; ``progress``:
    a terminal bar). ``checkpoint``: a file for the job's checkpoints (every
    ``checkpoint_every`` steps or ``checkpoint_s`` seconds), resumed from when it holds
    one of this spec; report.json then says ``resumed_from_step``; ``checkpoint_now`` (a
    ``threading.Event``) asks for a checkpoint at the next step once it is set.
    ``replace=False``: results another run committed to ``out_dir`` while this one ran are
    kept, and this run's go to ``OUT-2`` (the first free such name): the returned report
    then says so in ``out_dir`` and a warning. Raises
    :class:`inkmotion.errors.InkmotionError` subclasses for user-caused failures (bad
    input, unknown plugin); nothing is left in ``out_dir`` then.
    """
    from inkmotion.devices import configure_threads, resolve_device
    from inkmotion.outputs import StagingDir

    spec = with_threads(spec)
    resolved = resolve(spec)
    device = resolve_device(spec.device)
    threads = configure_threads(spec.threads)
    seed_everything(spec.seed)
    group = ObserverGroup([*standard_observers(spec, record=record, progress=progress,
                                               recording_id=recording_id), *observers])
    total = int(resolved.kind.steps(resolved.params))
    checkpoints = _checkpoints(Together(spec, Path(out_dir), checkpoint=checkpoint),
                               checkpoint_every, checkpoint_s, checkpoint_now)
    with StagingDir(Path(out_dir), replace=replace) as staging:
        try:
            job = Job(spec, resolved.params, device, staging.path, group, resolved, total,
                      checkpoints=checkpoints)
            report = _finished(job, _report_of(resolved.kind, job), threads)
            record_job(staging.path, resolved.full_spec(), report)
            group.on_end(report)
        finally:
            group.close()  # files complete (or released) before the folder moves
        staging.commit()
    if staging.diverted_from is not None:
        report = {**report, "out_dir": str(staging.final), "warnings": [
            *report.get("warnings", []),
            f"{staging.diverted_from} was written by another run while this one ran; its "
            f"results are kept, and this run's are in {staging.final}"]}
    return report


def with_threads(spec: JobSpec) -> JobSpec:
    """``spec`` with its thread count decided (:func:`inkmotion.devices.default_threads`
    when it names none): the count the job runs with from start to end, recorded in its
    job.json and report.json."""
    if spec.threads is not None:
        return spec
    from inkmotion.devices import default_threads

    spec = spec.copy()
    spec.threads = default_threads()
    return spec


def seed_everything(seed: int) -> None:
    """Seed torch, NumPy and ``random`` with a job's seed."""
    import numpy as np
    import torch

    torch.manual_seed(seed)
    np.random.seed(seed % 2**32)
    random.seed(seed)


@dataclass
class Together:
    """One job of :func:`run_jobs_together`: what :func:`run_job` takes for it alone."""

    spec: JobSpec
    out_dir: Path
    observers: Sequence[object] = ()
    recording_id: str | None = None
    checkpoint: Path | None = None


def batchable(specs: Sequence[JobSpec]) -> bool:
    """Whether these jobs can run as one batched optimisation: one kind that can, and the
    same parameters, plugins and device (only their inputs and seeds differ)."""
    if len(specs) < 2:
        return False
    kinds = {s.kind for s in specs}
    if len(kinds) != 1:
        return False
    resolved = resolve(specs[0])
    if getattr(resolved.kind, "run_together", None) is None:
        return False
    first = specs[0].to_dict()
    same = {k: v for k, v in first.items() if k not in ("inputs", "seed")}
    return all({k: v for k, v in s.to_dict().items() if k not in ("inputs", "seed")} == same
               for s in specs[1:])


def run_jobs_together(jobs: Sequence[Together], *, record: bool = False,
                      checkpoint_every: int | None = None, checkpoint_s: float | None = None,
                      checkpoint_now: Any = None, fallback: bool = True
                      ) -> list[dict | BaseException]:
    """Run several jobs of one kind as one batched optimisation (the kind's
    ``run_together``, :func:`batchable` jobs), each with its own staging folder, observers,
    checkpoint, job.json and report.json, committed on its own: the same artifacts as
    :func:`run_job` of each, up to float round-off of the batched arithmetic. Returns each
    job's report, or the exception it failed with. When the batch itself fails (a bad
    input, a NaN in one drawing), every job runs again alone, so one job's failure is its
    own and the others still finish; with ``fallback=False`` the batch's exception is
    raised instead (a worker that queues the jobs again)."""
    from contextlib import ExitStack

    from inkmotion.devices import configure_threads, resolve_device
    from inkmotion.outputs import StagingDir

    jobs = [replace(j, spec=with_threads(j.spec)) for j in jobs]
    specs = [j.spec for j in jobs]
    if not batchable(specs):
        return [_alone(j, record, checkpoint_every, checkpoint_s, checkpoint_now) for j in jobs]
    resolved = [resolve(spec) for spec in specs]
    device = resolve_device(specs[0].device)
    threads = configure_threads(specs[0].threads)
    groups: list[ObserverGroup] = []
    try:
        with ExitStack() as stack:
            stagings = [stack.enter_context(StagingDir(Path(j.out_dir))) for j in jobs]
            shells = []
            for j, r, staging in zip(jobs, resolved, stagings, strict=True):
                group = ObserverGroup([*standard_observers(
                    j.spec, record=record, progress=False, recording_id=j.recording_id),
                    *j.observers])
                groups.append(group)
                shells.append(Job(j.spec, r.params, device, staging.path, group, r,
                                  int(r.kind.steps(r.params)),
                                  checkpoints=_checkpoints(j, checkpoint_every, checkpoint_s,
                                                           checkpoint_now)))
            outcomes = list(resolved[0].kind.run_together(shells))
            for shell, outcome in zip(shells, outcomes, strict=True):
                if isinstance(outcome, BaseException):
                    continue
                _finished(shell, outcome, threads)["batch"] = len(shells)
                # job.json says so too: a rerun alone agrees only up to round-off
                outcome.setdefault("provenance", {})["batch"] = len(shells)
                record_job(shell.folder, shell.resolved.full_spec(), outcome)
                shell.observers.on_end(outcome)
            for group in groups:
                group.close()
            groups = []
            for staging, outcome in zip(stagings, outcomes, strict=True):
                if isinstance(outcome, BaseException):
                    staging.abort()  # a job that failed leaves nothing behind
                else:
                    staging.commit()
        return [o if isinstance(o, BaseException) else dict(o) for o in outcomes]
    except Exception:  # noqa: BLE001 - every job runs again alone and keeps its own outcome
        import logging

        for group in groups:
            group.close()
        if not fallback:
            raise
        logging.getLogger("inkmotion").warning(
            "a batch of %d %s jobs failed; running each alone", len(jobs), specs[0].kind,
            exc_info=True)
        return [_alone(j, record, checkpoint_every, checkpoint_s, checkpoint_now) for j in jobs]


def _finished(job: Job, report: dict, threads: int) -> dict:
    """The kind's ``report`` with what the shell adds: kind, wall time, device, threads."""
    report.update(kind=job.spec.kind, wall_s=round(time.perf_counter() - job.started, 3),
                  device=str(job.device), threads=threads)
    return report


def _checkpoints(job: Together, every: int | None, every_s: float | None, now: Any) -> Any:
    if job.checkpoint is None:
        return None
    from inkmotion.jobs import checkpoint as ck

    return ck.Checkpoints(job.checkpoint, job.spec.to_dict(), every or ck.EVERY_STEPS,
                          every_s or ck.EVERY_S, now=now)


def _alone(job: Together, record: bool, every: int | None, every_s: float | None,
           now: Any) -> dict | BaseException:
    try:
        return run_job(job.spec, job.out_dir, job.observers, record=record,
                       recording_id=job.recording_id, checkpoint=job.checkpoint,
                       checkpoint_every=every, checkpoint_s=every_s, checkpoint_now=now)
    except Exception as exc:  # noqa: BLE001 - the caller reports each job's own outcome
        return exc


def input_files(spec: JobSpec) -> dict[str, dict[str, str]]:
    """The job's inputs that are files (a ``sample:NAME`` its shipped file), each with its
    path and the SHA-256 of its bytes: job.json says which bytes a result was made from,
    and ``run --config`` says when the file has changed since (:func:`changed_inputs`)."""
    import hashlib

    from inkmotion.samples import locate

    out = {}
    for name, source in spec.inputs.items():
        path = Path(locate(source))  # a path or text:WORD comes back as it is
        try:
            if path.is_file():
                out[name] = {"path": str(path),
                             "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}
        except (OSError, ValueError):
            continue
    return out


def changed_inputs(job_json: dict[str, Any], spec: JobSpec) -> list[str]:
    """One sentence per input file of ``spec`` whose bytes differ from those the job.json
    ``job_json`` recorded (its ``input_files``): a rerun of it may not give its result."""
    recorded = job_json.get("input_files") or {}
    now = input_files(spec)
    said = []
    for name, was in recorded.items():
        if not isinstance(was, dict) or name not in now or now[name]["path"] != was.get("path"):
            continue
        if now[name]["sha256"] != was.get("sha256"):
            said.append(f"{was['path']} has changed since this job.json was written (its "
                        "bytes differ from those it records), so this run may not "
                        "reproduce the recorded result")
    return said


def unlike_the_record(job_json: dict[str, Any], spec: JobSpec) -> list[str]:
    """One sentence per reason a rerun of the job.json ``job_json`` here may not give its
    recorded result: an input file whose bytes changed (:func:`changed_inputs`), a plan
    made in a worker's batch (whose batched arithmetic agrees with a fit alone only up to
    float round-off), or torch's CPU code path other than the one it recorded."""
    said = changed_inputs(job_json, spec)
    batch = job_json.get("batch")
    if isinstance(batch, int) and batch > 1:
        said.append(f"this job was fitted in a worker's batch of {batch} drawings, whose "
                    "batched arithmetic agrees with a fit alone only up to float round-off, "
                    "so run alone its plan may differ (a worker with --batch 1 makes plans "
                    "that reproduce exactly)")
    was = (job_json.get("machine") or {}).get("cpu_capability")
    now = machine()["cpu_capability"]
    if isinstance(was, str) and now is not None and was != now and _on_the_cpu(spec):
        how = (f" (ATEN_CPU_CAPABILITY={was.lower()} runs the recorded path where the CPU "
               "has it)" if was in ("AVX512", "AVX2", "DEFAULT") else "")
        said.append(f"this job ran on torch's {was} CPU code path and this machine runs "
                    f"{now}: a fit of a drawing takes the same steps on both, but a CLIP "
                    f"model's, a picture tracer's or a plugin's kernels may round "
                    f"differently, so the result's last bits may differ{how}")
    return said


def _on_the_cpu(spec: JobSpec) -> bool:
    from inkmotion.devices import resolve_device
    from inkmotion.errors import InkmotionError

    try:
        return resolve_device(spec.device).type == "cpu"
    except InkmotionError:
        return False


def machine() -> dict[str, Any]:
    """What of this machine a CPU result depends on beyond the thread count: torch's CPU
    code path (``ATEN_CPU_CAPABILITY``: its vector kernels round some functions
    differently; a fit of a drawing avoids them, :mod:`inkmotion.portable_math`, but a
    CLIP model's products, for one, follow it)."""
    import torch

    try:
        capability = torch.backends.cpu.get_cpu_capability()
    except (AttributeError, RuntimeError):
        capability = None
    return {"cpu_capability": capability}


def record_job(folder: Path, spec: JobSpec, report: dict) -> None:
    """Write job.json (the spec, versions, seed, and the report's ``provenance``: what the
    result was made with beyond the spec, e.g. ``"clip_weights": "random"``) and report.json
    into ``folder``."""
    used = plugin_packages(spec)
    files = input_files(spec)
    job = {"spec": spec.to_dict(), "versions": {**versions(), **({"plugins": used} if used
                                                                  else {})},
           "machine": machine(), **({"input_files": files} if files else {}),
           "seed": spec.seed, **report.get("provenance", {})}
    (folder / "job.json").write_text(dumps(job, indent=1))
    (folder / "report.json").write_text(dumps(report, indent=1))
