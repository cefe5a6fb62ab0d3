"""Count the operations that would make the host wait for a CUDA device, on any device.

A CUDA step is fast only when the host never waits for the device: every kernel is queued
and the Python loop runs ahead. The host waits when it needs a value (``int(t)``,
``float(t)``, ``bool(t)``, ``t.item()``, ``t.tolist()``, ``t.numpy()``, ``t.cpu()``), when an
op's output shape depends on the data (``nonzero``, ``masked_select``, indexing with a bool
mask, ``repeat_interleave`` without ``output_size``, ``unique``) and when a tensor is made
from Python data (``torch.tensor([...])``: a blocking host-to-device copy on CUDA). None of
these cost anything on a CPU, so they go unnoticed there; :func:`count_host_syncs` records
them on the CPU too, so a test can assert that a step makes none.

Two interception layers are needed: a :class:`~torch.overrides.TorchFunctionMode` sees the
Python-level methods (``Tensor.item``, ``Tensor.__bool__``, ...), a
:class:`~torch.utils._python_dispatch.TorchDispatchMode` sees the aten ops, including those
run by the autograd engine in ``backward()`` and the scalar reads C++ does for Python
arguments (``torch.arange(t)``). An aten op inside a recorded Python-level call is not
counted a second time.
"""

from __future__ import annotations

import sys
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch
from torch.overrides import TorchFunctionMode
from torch.utils._python_dispatch import TorchDispatchMode

_T = torch.Tensor

#: Python-level methods and functions that read a value on the host
_READS: dict[Callable[..., Any], str] = {
    _T.item: "Tensor.item",
    _T.tolist: "Tensor.tolist",
    _T.__int__: "Tensor.__int__",
    _T.__float__: "Tensor.__float__",
    _T.__bool__: "Tensor.__bool__",
    _T.__index__: "Tensor.__index__",
    _T.__complex__: "Tensor.__complex__",
    _T.__format__: "Tensor.__format__",
    _T.__repr__: "Tensor.__repr__",
    _T.__array__: "Tensor.__array__",
    _T.__contains__: "Tensor.__contains__",
    _T.numpy: "Tensor.numpy",
    _T.cpu: "Tensor.cpu",
    _T.equal: "Tensor.equal",
    _T.allclose: "Tensor.allclose",
    _T.is_nonzero: "Tensor.is_nonzero",
    torch.equal: "torch.equal",
    torch.allclose: "torch.allclose",
    torch.is_nonzero: "torch.is_nonzero",
}

#: functions that copy Python data to the tensor's device (blocking on CUDA)
_UPLOADS: dict[Callable[..., Any], str] = {
    torch.tensor: "torch.tensor (upload)",
    torch.as_tensor: "torch.as_tensor (upload)",
    torch.asarray: "torch.asarray (upload)",
    torch.from_numpy: "torch.from_numpy (upload)",
}

#: aten ops whose output shape (or Python result) depends on the data
_DATA_DEPENDENT = {
    "_local_scalar_dense": "aten._local_scalar_dense (item)",
    "nonzero": "aten.nonzero",
    "masked_select": "aten.masked_select",
    "_unique": "aten.unique",
    "_unique2": "aten.unique",
    "unique_dim": "aten.unique",
    "unique_consecutive": "aten.unique_consecutive",
    "unique_dim_consecutive": "aten.unique_consecutive",
    "is_nonzero": "aten.is_nonzero",
    "equal": "aten.equal",
    "bincount": "aten.bincount",
    "_linalg_check_errors": "aten._linalg_check_errors",
}

_INDEX_OPS = {"index", "index_put", "index_put_", "_index_put_impl", "_index_put_impl_"}
_COPY_OPS = {"_to_copy", "copy_", "_copy_from"}


@dataclass(frozen=True)
class HostSync:
    """One operation that would synchronise: what it is and where the caller is."""

    name: str
    where: str


@dataclass
class HostSyncLog:
    """The host synchronisations recorded inside one :func:`count_host_syncs` block."""

    events: list[HostSync] = field(default_factory=list)

    @property
    def count(self) -> int:
        return len(self.events)

    def names(self) -> Counter[str]:
        """How often each kind of operation was seen."""
        return Counter(e.name for e in self.events)

    def summary(self) -> str:
        """One line per (operation, caller) with its count, most frequent first."""
        rows = Counter((e.name, e.where) for e in self.events).most_common()
        return "\n".join(f"{n:4d}  {name:45s} {where}" for (name, where), n in rows)


def _caller() -> str:
    """``file:line`` of the innermost frame outside torch and this module."""
    frame = sys._getframe(2)
    torch_dir = str(Path(torch.__file__).parent)
    here = __file__
    while frame is not None:
        name = frame.f_code.co_filename
        if not (name.startswith(torch_dir) or name == here or "contextlib" in name):
            return f"{Path(name).name}:{frame.f_lineno} ({frame.f_code.co_name})"
        frame = frame.f_back
    return "?"


def _has_bool_index(args: tuple) -> bool:
    """True when an aten index/index_put call indexes with a bool (or uint8) mask."""
    indices = args[1] if len(args) > 1 else ()
    return any(isinstance(i, torch.Tensor) and i.dtype in (torch.bool, torch.uint8)
               for i in indices or ())


def _crosses_host(func: Any, args: tuple, kwargs: dict) -> bool:
    """True for a blocking copy between the host and a device (either direction)."""
    name = func.overloadpacket.__name__
    if name == "_to_copy":
        src, dst = args[0], kwargs.get("device") or args[0].device
        blocking = not kwargs.get("non_blocking", False)
    else:  # copy_(self=dst, src, non_blocking), _copy_from(self=src, dst, non_blocking)
        dst, src = (args[0], args[1]) if name == "copy_" else (args[1], args[0])
        dst = dst.device
        blocking = not (args[2] if len(args) > 2 else kwargs.get("non_blocking", False))
    return blocking and (src.device.type == "cpu") != (torch.device(dst).type == "cpu")


def data_dependent_op(func: Any, args: tuple, kwargs: dict) -> str | None:
    """The name under which an aten op is recorded as a host sync, or None."""
    name = func.overloadpacket.__name__
    if name in _DATA_DEPENDENT:
        return _DATA_DEPENDENT[name]
    if name == "repeat_interleave" and func._overloadname == "Tensor" \
            and kwargs.get("output_size") is None:
        return "aten.repeat_interleave (no output_size)"
    if name in _INDEX_OPS and _has_bool_index(args):
        return f"aten.{name} (bool mask)"
    if name in _COPY_OPS and _crosses_host(func, args, kwargs):
        return f"aten.{name} (host <-> device)"
    return None


class _FunctionLayer(TorchFunctionMode):
    """Records Python-level reads and uploads; marks the dispatch layer as inside one."""

    def __init__(self, log: HostSyncLog, state: dict[str, int]) -> None:
        super().__init__()
        self.log, self.state = log, state

    def __torch_function__(self, func: Any, types: Any, args: tuple = (),
                           kwargs: dict | None = None) -> Any:
        kwargs = kwargs or {}
        name = _READS.get(func)
        if name is None and func in _UPLOADS and args \
                and not isinstance(args[0], torch.Tensor):
            name = _UPLOADS[func]
        if name is None:
            return func(*args, **kwargs)
        self.log.events.append(HostSync(name, _caller()))
        self.state["inside"] += 1
        try:
            return func(*args, **kwargs)
        finally:
            self.state["inside"] -= 1


class _DispatchLayer(TorchDispatchMode):
    """Records aten ops with data-dependent shapes or scalar reads (also in backward)."""

    def __init__(self, log: HostSyncLog, state: dict[str, int]) -> None:
        super().__init__()
        self.log, self.state = log, state

    def __torch_dispatch__(self, func: Any, types: Any, args: tuple = (),
                           kwargs: dict | None = None) -> Any:
        kwargs = kwargs or {}
        if self.state["inside"] == 0:
            name = data_dependent_op(func, args, kwargs)
            if name is not None:
                self.log.events.append(HostSync(name, _caller()))
        return func(*args, **kwargs)


@contextmanager
def count_host_syncs() -> Iterator[HostSyncLog]:
    """Record every operation in the block that would synchronise with a CUDA device.

    ``with count_host_syncs() as log: ...`` then ``log.count``, ``log.names()``,
    ``log.summary()``. Works on any device (the CPU included), for forward and backward.
    """
    log = HostSyncLog()
    state = {"inside": 0}
    with _FunctionLayer(log, state), _DispatchLayer(log, state):
        yield log


@contextmanager
def forbid_cuda_syncs() -> Iterator[None]:
    """On a CUDA machine, make every synchronising CUDA call in the block raise
    (``torch.cuda.set_sync_debug_mode("error")``): the device's own check, which also sees
    what no Python mode can (a blocking copy inside a kernel's host code). A no-op without
    CUDA."""
    if not torch.cuda.is_available():
        yield
        return
    previous = torch.cuda.get_sync_debug_mode()
    torch.cuda.set_sync_debug_mode("error")
    try:
        yield
    finally:
        torch.cuda.set_sync_debug_mode(previous)
