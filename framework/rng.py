"""The global random generators' states (torch, NumPy, Python), to save and restore them
with a checkpoint so that a resumed run draws the same numbers as an uninterrupted one.

The states are plain data (tensors, numbers, tuples), so a checkpoint holding them loads
with ``torch.load(weights_only=True)``: NumPy's key array travels as an int64 tensor."""

from __future__ import annotations

import random
from typing import Any


def rng_states() -> dict[str, Any]:
    """The states of torch's, NumPy's and Python's global generators (plain data)."""
    import numpy as np
    import torch

    name, keys, pos, has_gauss, cached = np.random.get_state()
    numpy_state = (str(name), torch.from_numpy(np.asarray(keys, dtype=np.int64)), int(pos),
                   int(has_gauss), float(cached))
    return {"torch": torch.get_rng_state(), "numpy": numpy_state,
            "python": random.getstate()}


def restore_rng(states: dict[str, Any]) -> None:
    """Set the three generators back to ``states`` (from :func:`rng_states`)."""
    import numpy as np
    import torch

    torch.set_rng_state(states["torch"])
    name, keys, pos, has_gauss, cached = states["numpy"]
    keys = keys.numpy() if isinstance(keys, torch.Tensor) else np.asarray(keys)
    np.random.set_state((name, keys.astype(np.uint32), pos, has_gauss, cached))
    random.setstate(states["python"])
