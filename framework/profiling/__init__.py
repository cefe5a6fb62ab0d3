"""Profiling helpers: count the host synchronisations a step would make on CUDA."""

from inkmotion.profiling.host_syncs import (
    HostSync,
    HostSyncLog,
    count_host_syncs,
    forbid_cuda_syncs,
)

__all__ = ["HostSync", "HostSyncLog", "count_host_syncs", "forbid_cuda_syncs"]
