"""Recording overhead: the time of an optimisation step with the rerun recorder on vs off.

Both runs are real fits (same spec, same seed). The step time is the mean interval between
consecutive ``on_step`` calls after a warm-up, taken by a tiny timing observer, so reading
the input and writing artifacts do not dilute the ratio. The recorder's share includes
what the runner builds for it (rendered images every k steps, per-step geometry).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from inkmotion.events import StepState
from inkmotion.jobs.spec import JobSpec


class _StepClock:
    """Observer recording the wall time of every step."""

    def __init__(self) -> None:
        self.times: list[float] = []

    def on_step(self, state: StepState) -> None:
        self.times.append(time.perf_counter())

    def step_ms(self, skip: int = 5) -> float:
        """Mean step time after ``skip`` warm-up steps (a mean, not a median, so the
        images logged every k steps count)."""
        t = self.times[skip:]
        return 1e3 * (t[-1] - t[0]) / (len(t) - 1)


class _TimedRecorder:
    """The recorder, with the time spent inside its ``on_step`` summed."""

    def __init__(self, record_every: int) -> None:
        from inkmotion.recording.recorder import RerunRecorder

        self.inner = RerunRecorder(image_every=record_every)
        self.wants_image = self.inner.wants_image
        self.wants_geometry = self.inner.wants_geometry
        self.on_start = self.inner.on_start
        self.on_end = self.inner.on_end
        self.close = self.inner.close
        self.spent = 0.0
        self.steps = 0

    def on_step(self, state: StepState) -> None:
        t = time.perf_counter()
        self.inner.on_step(state)
        self.spent += time.perf_counter() - t
        self.steps += 1


def _step_ms(spec: JobSpec, record: bool, folder: Path) -> tuple[float, float]:
    """(mean step ms, ms per step spent inside the recorder)."""
    from inkmotion.jobs.shell import run_job

    clock = _StepClock()
    observers: list[object] = [clock]
    recorder = _TimedRecorder(spec.record_every) if record else None
    if recorder is not None:
        observers.insert(0, recorder)
    run_job(spec, folder, observers=observers)
    own = 1e3 * recorder.spent / max(recorder.steps, 1) if recorder else 0.0
    return clock.step_ms(), own


def bench_recording(input: str | None = None, steps: int = 60, size: int = 350,
                    record_every: int = 10, repeats: int = 2) -> dict[str, float]:
    """Mean step time (ms) without and with the recorder, and their ratio (target ≤ 1.1).

    Off and on runs alternate ``repeats`` times and the best of each is kept, which damps
    noise from other processes on the machine. ``input`` defaults to the fit benchmark's
    (:func:`inkmotion.benchmarks.fit.default_fit_input`: a shipped sample tag).
    ``recording_own_ms`` is the time per step
    spent inside the recorder itself (a steadier figure than the difference of two walls).
    """
    from inkmotion.benchmarks.fit import default_fit_input

    spec = JobSpec(kind="fit", inputs={"drawing": input or default_fit_input()},
                   device="cpu", record_every=record_every,
                   params={"steps": steps, "size": size})
    off: list[float] = []
    on: list[tuple[float, float]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(repeats):
            off.append(_step_ms(spec, False, Path(tmp) / f"off{k}")[0])
            on.append(_step_ms(spec, True, Path(tmp) / f"on{k}"))
    step_off = min(off)
    step_on, own = min(on)
    return {
        "recording_step_off_ms": step_off,
        "recording_step_on_ms": step_on,
        "recording_own_ms": own,
        "recording_ratio": step_on / step_off,
    }
