"""Devices and threads for a job: ``auto`` picks CUDA when present.

Determinism policy. On the CPU a job reproduces exactly: the same spec and seed give a
bitwise-identical plan.json (tests check it). On CUDA the scatter-adds of the kinematics
and the renderer (``index_add``, ``scatter_reduce``) use atomics whose summation order
varies, so two runs agree within float32 round-off that the optimiser may amplify: we
promise the fitted virtual targets within 0.05 px and the loss terms within 1e-3
relative, not bit equality (``torch.use_deterministic_algorithms`` would make those ops
raise on CUDA, so it is not switched on).

Threads. A job's thread count is part of its spec (``threads`` in job.json): decided once,
before the job starts, from the spec, else ``INKMOTION_THREADS`` (or ``OMP_NUM_THREADS``),
else :data:`DEFAULT_THREADS`; recorded in job.json and report.json; never changed while the
job runs, and never taken from what else runs on the machine. CPU results depend on it
(torch's reductions and MKL's small products split their work by thread, and a last-bit
difference can tip a plan edit), so a result is a function of its job.json and the
machine only: ``inkmotion run --config job.json`` runs with the count it recorded.

Why one thread by default: a fit's ops are small and many (about a thousand per step), so
a second intra-op thread buys nothing measurable (49867.json, default fit on this 2-core
machine: 5.22 s of fit with 1 thread, 5.26 s with 2, for 1.6× the CPU time), while threads
that outnumber the cores wait on each other at every OpenMP barrier. With one thread each,
jobs side by side cost what they cost alone, up to the machine's shared caches and memory
bandwidth. Inter-op threads are 1 (nothing here runs ops concurrently).
"""

from __future__ import annotations

import os
from typing import Any

from inkmotion.errors import SpecError


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


#: a job's torch intra-op threads when neither its spec nor the environment says
#: (module docstring: a fit gains nothing measurable from a second thread)
DEFAULT_THREADS = 1


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity, else the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


def _env_int(name: str) -> int | None:
    value = os.environ.get(name, "").strip()
    return int(value) if value.isdigit() and int(value) > 0 else None


def default_threads() -> int:
    """Intra-op threads of a job whose spec names none: ``INKMOTION_THREADS`` (or
    ``OMP_NUM_THREADS``, when it is one number) when set, else :data:`DEFAULT_THREADS`.
    Nothing about the jobs running beside it enters (module docstring). An
    ``INKMOTION_THREADS`` that is not a positive whole number is refused (OpenMP's own
    variable may hold more than a number, and is then not ours to judge)."""
    raw = os.environ.get("INKMOTION_THREADS", "").strip()
    if raw and _env_int("INKMOTION_THREADS") is None:
        raise SpecError(f"INKMOTION_THREADS={raw!r} is not a positive whole number; set it "
                        "to the CPU threads a job should use (e.g. 2) or unset it.")
    for env in ("INKMOTION_THREADS", "OMP_NUM_THREADS"):
        if (value := _env_int(env)) is not None:
            return value
    return DEFAULT_THREADS


def configure_threads(threads: int | None = None) -> int:
    """Set torch's intra-op thread count to ``threads`` (None: :func:`default_threads`) and a
    single inter-op thread; returns the intra-op count."""
    import torch

    n = threads or default_threads()
    if torch.get_num_threads() != n:
        torch.set_num_threads(n)
    if torch.get_num_interop_threads() != 1:
        try:
            torch.set_num_interop_threads(1)
        except RuntimeError:  # inter-op work already ran in this process: keep its pool
            pass
    return n
