"""Checkpoints of a running job, so that a job redelivered after its worker died resumes
where the dead attempt left off instead of at step 0.

A checkpoint is one file in the job's own storage (not in the staging folder, which a new
attempt removes), written every ``every_steps`` steps or ``every_s`` seconds, whichever
comes first, with ``torch.save`` into a temporary sibling renamed into place
(``os.replace``): a reader finds the previous complete checkpoint or the new one, never a
half-written file. It holds what the job kind needs to continue bit for bit — for a fit:
the stage, the plans it started from, the optimiser's parameters and Adam moments, the
step, the record of the stages so far, and the RNG states — plus a fingerprint of the job
spec, so a checkpoint of another spec is never resumed (it is ignored and overwritten).

A checkpoint is data, never code: it holds tensors, numbers, strings, lists, tuples and
dicts only, and is read with ``torch.load(weights_only=True)``, which builds nothing else.
Whoever can write the data directory can therefore make a worker start a job over, but not
run code on it: a file that is not such a checkpoint is refused with one warning sentence
and the job starts from step 0. A state with anything else in it is a bug of the job kind
that saves it, caught when it is saved (:func:`check_plain`).
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from pathlib import Path
from typing import Any

from inkmotion.rng import restore_rng, rng_states  # noqa: F401  (re-exported)

#: defaults: a checkpoint every this many steps or seconds, whichever comes first
EVERY_STEPS = 50
EVERY_S = 30.0


def spec_fingerprint(spec: dict[str, Any]) -> str:
    """A short hash of the job spec (its JSON, keys sorted)."""
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:16]


class Checkpoints:
    """The checkpoint file of one job (module docstring)."""

    def __init__(self, path: str | Path, spec: dict[str, Any], every_steps: int = EVERY_STEPS,
                 every_s: float = EVERY_S, now: Any = None) -> None:
        self.path = Path(path)
        self.fingerprint = spec_fingerprint(spec)
        self.every_steps, self.every_s = max(1, int(every_steps)), float(every_s)
        self._last_step = 0
        self._last_time = time.monotonic()
        self.saved = 0
        self.save_s = 0.0  # total time spent writing checkpoints
        self.now = now  # a threading.Event: once set, a checkpoint is due at once (shutdown)
        self._final_done = False

    def due(self, step: int) -> bool:
        """Whether a checkpoint should be written after ``step``."""
        if self.now is not None and self.now.is_set() and not self._final_done:
            self._final_done = True
            return True
        return (step - self._last_step >= self.every_steps
                or time.monotonic() - self._last_time >= self.every_s)

    def save(self, step: int, state: dict[str, Any]) -> None:
        """Write ``state`` (tensors and plain data) as the checkpoint after ``step``."""
        import torch

        started = time.perf_counter()
        check_plain(state)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(f"{self.path.name}.partial-{os.getpid()}")
        torch.save({"fingerprint": self.fingerprint, "step": step, "state": state,
                    "threads": torch.get_num_threads()}, tmp)
        os.replace(tmp, self.path)
        self._last_step, self._last_time = step, time.monotonic()
        self.saved += 1
        self.save_s += time.perf_counter() - started

    def load(self) -> dict[str, Any] | None:
        """The saved state when a checkpoint of this spec exists, else None (a missing,
        unreadable or foreign checkpoint is ignored)."""
        import torch

        if not self.path.is_file():
            return None
        try:
            saved = torch.load(self.path, weights_only=True)
        except Exception as exc:  # a torn file, or one that is not data: start afresh
            import pickle

            reason = ("it holds objects other than tensors and plain values, which are never "
                      "loaded" if isinstance(exc, pickle.UnpicklingError)
                      else "it is not a complete file that torch.save wrote")
            _start_over(self.path, reason)
            return None
        if not isinstance(saved, dict) or saved.get("fingerprint") != self.fingerprint:
            return None
        step, state = saved.get("step"), saved.get("state")
        if isinstance(step, bool) or not isinstance(step, int) or step < 0 \
                or not isinstance(state, dict):
            _start_over(self.path, "it has no step count or state of the kind inkmotion "
                        "saves")
            return None
        self._last_step = step
        made_with = saved.get("threads")
        if made_with is not None and made_with != torch.get_num_threads():
            import logging

            logging.getLogger("inkmotion").warning(
                "resuming a checkpoint made with %s torch threads on %s: the result may "
                "differ from an uninterrupted run in the last bits (INKMOTION_THREADS=%s "
                "reproduces it)", made_with, torch.get_num_threads(), made_with)
        return dict(state, step=step)

    def start_over(self, reason: str) -> None:
        """Say that the loaded state cannot be resumed, and why (a job kind found its own
        part of it malformed): the job starts over from step 0."""
        _start_over(self.path, reason)

    def remove(self) -> None:
        """Delete the checkpoint (the job finished): :func:`remove_checkpoint`."""
        remove_checkpoint(self.path)


def _start_over(path: Path, reason: str) -> None:
    """Say that the checkpoint at ``path`` is not used, and why, in one warning sentence."""
    import logging

    logging.getLogger("inkmotion").warning(
        "%s is not a checkpoint this job can resume (%s); the job starts over from step 0.",
        path, reason)


def remove_checkpoint(path: Path) -> None:
    """Delete the checkpoint file ``path`` and the half-written ones (``NAME.partial-PID``)
    of attempts killed while they saved, so that nothing of a finished job's checkpoints is
    left beside its results."""
    path.unlink(missing_ok=True)
    for partial in path.parent.glob(f"{path.name}.partial-*"):
        partial.unlink(missing_ok=True)


def check_plain(value: Any, where: str = "state") -> None:
    """Assert that ``value`` is plain data that ``torch.load(weights_only=True)`` reads back:
    tensors, None, bool, int, float, str, and lists, tuples and dicts (string keys) of them."""
    import torch

    if value is None or isinstance(value, (bool, int, float, str, torch.Tensor)):
        return
    if isinstance(value, (list, tuple)):
        for k, item in enumerate(value):
            check_plain(item, f"{where}[{k}]")
        return
    if isinstance(value, dict):
        for key, item in value.items():
            assert isinstance(key, (str, int)), f"checkpoint {where}: key {key!r} is not plain"
            check_plain(item, f"{where}[{key!r}]")
        return
    raise AssertionError(f"checkpoint {where} is a {type(value).__name__}, not plain data "
                         "(tensors, numbers, strings, lists, tuples, dicts)")
