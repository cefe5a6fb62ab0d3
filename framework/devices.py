"""Devices and threads for a job: ``auto`` picks CUDA when present.

Determinism policy. On the CPU a job reproduces exactly: the same spec and seed give a
bitwise-identical plan.json (tests check it). On CUDA the scatter-adds of the kinematics
and the renderer (``index_add``, ``scatter_reduce``) use atomics whose summation order
varies, so two runs agree within float32 round-off that the optimiser may amplify: we
promise the fitted virtual targets within 0.05 px and the loss terms within 1e-3
relative, not bit equality (``torch.use_deterministic_algorithms`` would make those ops
raise on CUDA, so it is not switched on).

Threads. A job's ops are small and many (about a thousand per fit step), so an intra-op
thread buys little (a lone default fit: about 10 % faster with 2 threads than with 1 on 2
cores), and threads that outnumber the cores wait on each other at every OpenMP barrier
(two fits of 2 threads each on 2 cores: 50× slower each). The policy
(:func:`default_threads`): ``INKMOTION_THREADS`` (or ``OMP_NUM_THREADS``) when set; else
the cores this process may use divided by the jobs that share them, at most
``MAX_DEFAULT_THREADS``. Who shares them: a worker or benchmark with n slots says so in
``INKMOTION_JOB_SLOTS`` (each of its n processes gets cores // n); a lone ``inkmotion run``
counts the other inkmotion jobs running on this machine when it starts (a registry of
pid files, :class:`RunningJobs`, read and written under one lock), and lowers its count
to its share when others start after it (:class:`ShareCores`). Inter-op threads are 1
(nothing here runs ops concurrently), and a process whose slots share the cores asks
OpenMP not to spin (``OMP_WAIT_POLICY=PASSIVE``, before torch loads).

The thread count is part of a CPU result: torch's large reductions and MKL's small matrix
products split their work by thread, so 1 and 2 threads give plans that differ in the last
bits (never in quality). report.json records ``threads``; a job run again with
``INKMOTION_THREADS`` set to it reproduces its plan.json bit for bit on the same machine
(another CPU's math kernels move the last bits too: docs/formats.md, job.json), and a
checkpoint records it too (a resume with another count says so).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from inkmotion.errors import SpecError

MAX_DEFAULT_THREADS = 4


def resolve_device(name: str) -> Any:
    """The torch device for a spec's ``device`` ("cpu", "cuda", "cuda:1", "auto")."""
    import torch

    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except RuntimeError as exc:
        raise SpecError(f"device={name!r} is not a torch device; use cpu, cuda or auto.") from exc
    if device.type not in ("cpu", "cuda"):
        raise SpecError(f"device={name!r} is not supported; use cpu, cuda or auto.")
    if device.type == "cuda":
        if not torch.cuda.is_available():
            raise SpecError(f"device={name!r} was asked for but no CUDA GPU is available; "
                            "use --device cpu (or auto).")
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise SpecError(f"device={name!r}: this machine has {torch.cuda.device_count()} "
                            "CUDA device(s); pick one of them or use auto.")
    return device


#: the environment variable a worker or benchmark sets for its processes: how many jobs
#: share this machine's cores at once (see the module docstring)
SLOTS_ENV = "INKMOTION_JOB_SLOTS"


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity, else the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


def threads_per_job(slots: int = 1, cores: int | None = None) -> int:
    """Intra-op threads of one of ``slots`` jobs sharing ``cores`` (default: this process's):
    max(1, cores // slots), at most :data:`MAX_DEFAULT_THREADS`."""
    cores = available_cores() if cores is None else cores
    return max(1, min(MAX_DEFAULT_THREADS, cores // max(1, slots)))


def _env_int(name: str) -> int | None:
    value = os.environ.get(name, "").strip()
    return int(value) if value.isdigit() and int(value) > 0 else None


def lone() -> bool:
    """Whether this job's thread count comes from its neighbours at start (no override, no
    slots): then :class:`ShareCores` may lower it when others start later."""
    return all(_env_int(e) is None for e in ("INKMOTION_THREADS", "OMP_NUM_THREADS",
                                             SLOTS_ENV))


class ShareCores:
    """A job observer for a lone run that took the cores it found free: every few seconds
    it looks at the registry, and when other inkmotion jobs have started since, it lowers
    torch's thread count to this job's share (never raises it). Threads that outnumber the
    cores wait on each other at every barrier, so the run that came first would otherwise
    be twice as slow. The change is recorded (``threads_lowered`` in report.json: the step
    and the new count): from that step on, the run is no longer bit for bit the run of its
    first thread count."""

    def __init__(self, running: RunningJobs, threads: int, every_s: float = 2.0) -> None:
        import time

        self.running, self.threads, self.every_s = running, threads, every_s
        self._next = time.monotonic() + every_s
        self.lowered: list[dict[str, int]] = []

    def on_step(self, state: Any) -> None:
        import time

        now = time.monotonic()
        if now < self._next or self.threads <= 1:
            return
        self._next = now + self.every_s
        share = threads_per_job(1 + self.running.others())
        if share < self.threads:
            import logging

            import torch

            torch.set_num_threads(share)
            self.threads = share
            self.lowered.append({"step": int(state.step), "threads": share})
            logging.getLogger("inkmotion").info(
                "other inkmotion jobs started: %d torch thread(s) from step %d", share,
                state.step)

    def on_end(self, report: dict) -> None:
        if self.lowered:
            report["threads_lowered"] = self.lowered


def default_threads(running: RunningJobs | None = None) -> int:
    """Intra-op threads for a job now (the policy of the module docstring). With
    ``running``, this process is registered there with its count, the look at its
    neighbours and the registration under one lock: two runs started at the same moment
    do not both take every core."""
    running = running or RunningJobs()
    for env in ("INKMOTION_THREADS", "OMP_NUM_THREADS"):
        if (value := _env_int(env)) is not None:
            return value
    slots = _env_int(SLOTS_ENV)
    if slots is not None:
        return threads_per_job(slots)
    with running.locked():
        return threads_per_job(1 + running.others())


def share_cores(slots: int) -> int:
    """For a process about to start ``slots`` jobs side by side (a worker pool, a benchmark):
    tell them through the environment they hand to their children, before torch loads;
    returns each job's thread count."""
    os.environ[SLOTS_ENV] = str(max(1, slots))
    if slots > 1:
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    return default_threads()


def configure_threads(threads: int | None = None, running: RunningJobs | None = None) -> int:
    """Set torch's intra-op thread count (``None``: :func:`default_threads`, registering
    this process in ``running`` when given) and a single inter-op thread; returns the
    intra-op count."""
    import torch

    if running is None:
        n = threads or default_threads()
    else:
        with running.locked():
            n = threads or default_threads(running)
            running.enter(n)
    if torch.get_num_threads() != n:
        torch.set_num_threads(n)
    if torch.get_num_interop_threads() != 1:
        try:
            torch.set_num_interop_threads(1)
        except RuntimeError:  # inter-op work already ran in this process: keep its pool
            pass
    return n


class RunningJobs:
    """The inkmotion jobs running on this machine: one file per process, named by its pid,
    holding its thread count, in ``INKMOTION_RUN_DIR`` (default: a folder of the user's
    temporary directory). A file whose process is gone does not count (and is removed)."""

    def __init__(self, folder: str | os.PathLike | None = None) -> None:
        import tempfile
        from pathlib import Path

        base = folder or os.environ.get("INKMOTION_RUN_DIR") or (
            Path(tempfile.gettempdir()) / f"inkmotion-running-{os.getuid()}"
            if hasattr(os, "getuid") else Path(tempfile.gettempdir()) / "inkmotion-running")
        self.folder = Path(base)
        self._depth = 0

    def _live(self) -> list[int]:
        pids = []
        try:
            entries = list(self.folder.iterdir())
        except OSError:
            return []
        for entry in entries:
            if not entry.name.isdigit():
                continue
            pid = int(entry.name)
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                entry.unlink(missing_ok=True)
                continue
            except PermissionError:  # alive, another user's
                pass
            pids.append(pid)
        return pids

    @contextmanager
    def locked(self) -> Iterator[None]:
        """Hold the registry's lock (re-entrant in this process): a look at the running
        jobs and a registration in one step."""
        if self._depth:
            self._depth += 1
            try:
                yield
            finally:
                self._depth -= 1
            return
        handle = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            handle = open(self.folder / "lock", "a")  # noqa: SIM115 - held for the block
            import fcntl

            fcntl.flock(handle, fcntl.LOCK_EX)
        except (OSError, ImportError):  # no lock here (read-only, Windows): best effort
            pass
        self._depth = 1
        try:
            yield
        finally:
            self._depth = 0
            if handle is not None:
                handle.close()  # releases the lock

    def others(self) -> int:
        """How many other processes are running inkmotion jobs now."""
        return sum(1 for pid in self._live() if pid != os.getpid())

    def enter(self, threads: int) -> None:
        """Register this process (with its thread count) until :meth:`leave` or its exit."""
        import atexit

        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            (self.folder / str(os.getpid())).write_text(str(threads))
        except OSError:  # a read-only temporary folder: neighbours just will not see us
            return
        atexit.register(self.leave)

    def leave(self) -> None:
        (self.folder / str(os.getpid())).unlink(missing_ok=True)
