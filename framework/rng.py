"""The global random generators' states (torch, NumPy, Python), to save and restore them
with a checkpoint so that a resumed run draws the same numbers as an uninterrupted one."""

from __future__ import annotations

import random
from typing import Any


def rng_states() -> dict[str, Any]:
    """The states of torch's, NumPy's and Python's global generators."""
    import numpy as np
    import torch

    return {"torch": torch.get_rng_state(), "numpy": np.random.get_state(),
            "python": random.getstate()}


def restore_rng(states: dict[str, Any]) -> None:
    """Set the three generators back to ``states`` (from :func:`rng_states`)."""
    import numpy as np
    import torch

    torch.set_rng_state(states["torch"])
    np.random.set_state(states["numpy"])
    random.setstate(states["python"])
