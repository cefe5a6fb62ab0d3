"""Numbers as 0-d tensors of a tensor's dtype and device, made once per process.

An op between a tensor and a Python number wraps the number into a float64 tensor and
casts it to the tensor's dtype on every call, and autograd does the same again when the
op's backward multiplies by the number: about 2 µs of a fit step's 4 per op on this
project's small tensors (a step is some 1900 ops). A 0-d tensor of the right dtype takes
the same kernel (a CPU scalar operand), rounded to the dtype as the number was: the same
bits, without the wrapping and the cast.
"""

from __future__ import annotations

import torch

_MADE: dict[tuple, tuple[torch.Tensor, ...]] = {}


def scalar_tensors(like: torch.Tensor, *values: float) -> tuple[torch.Tensor, ...]:
    """``values`` as 0-d tensors of ``like``'s dtype and device (each rounded from
    float64, as an op rounds a Python number), made on the first call for that dtype and
    device and reused after (never write into them)."""
    key = (values, like.dtype, like.device)
    made = _MADE.get(key)
    if made is None:
        made = _MADE[key] = tuple(
            torch.tensor(values, dtype=torch.float64).to(device=like.device,
                                                         dtype=like.dtype).unbind(0))
    return made
