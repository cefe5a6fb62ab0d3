"""Devices and threads for a job: ``auto`` picks CUDA when present.

Determinism policy. On the CPU a job reproduces exactly: the same spec and seed give a
bitwise-identical plan.json (tests check it). On CUDA the scatter-adds of the kinematics
and the renderer (``index_add``, ``scatter_reduce``) use atomics whose summation order
varies, so two runs agree within float32 round-off that the optimiser may amplify: we
promise the fitted virtual targets within 0.05 px and the loss terms within 1e-3
relative, not bit equality (``torch.use_deterministic_algorithms`` would make those ops
raise on CUDA, so it is not switched on).

Threads. PyTorch's default (one thread per core) is a poor fit for this workload: its
ops are small and many, and on a 16-core machine 16 threads ran the reference fit 2×
slower than 2. Unless the user set ``INKMOTION_THREADS`` (or ``OMP_NUM_THREADS``), a job
uses min(4, available cores) intra-op threads.
"""

from __future__ import annotations

import os
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


def default_threads() -> int:
    """Intra-op threads for a job (see the module docstring)."""
    for env in ("INKMOTION_THREADS", "OMP_NUM_THREADS"):
        value = os.environ.get(env, "").strip()
        if value.isdigit() and int(value) > 0:
            return int(value)
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        cores = os.cpu_count() or 1
    return max(1, min(MAX_DEFAULT_THREADS, cores))


def configure_threads(threads: int | None = None) -> int:
    """Set torch's intra-op thread count (``None``: :func:`default_threads`); returns it."""
    import torch

    n = threads or default_threads()
    if torch.get_num_threads() != n:
        torch.set_num_threads(n)
    return n
