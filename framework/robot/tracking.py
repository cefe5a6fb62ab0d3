"""Tracking error of an executed pen-tip path against its plan, split along the drawing
plane's normal (what shows on the paper, and the press depth): one computation for the
simulated arm and the real one."""

from __future__ import annotations

import numpy as np


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of the runs of True in a boolean array."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2], edges[1::2], strict=True))


def trim(mask: np.ndarray, margin: int) -> np.ndarray:
    """``mask`` with ``margin`` samples removed at both ends of each of its runs."""
    out = np.zeros_like(mask)
    for start, stop in runs(mask):
        if stop - start > 2 * margin:
            out[start + margin:stop - margin] = True
    return out


def error_stats(err: np.ndarray, mask: np.ndarray, normal: np.ndarray,
                prefix: str) -> dict[str, float]:
    """RMS / max (mm) of the in-plane and normal parts of errors (N, 3) m over ``mask``."""
    if not mask.any():
        return {}
    e = err[mask]
    e_n = e @ normal
    e_t = np.linalg.norm(e - e_n[:, None] * normal, axis=1)
    e_3 = np.linalg.norm(e, axis=1)
    return {
        f"{prefix}_plane_rms_mm": 1e3 * float(np.sqrt(np.mean(e_t**2))),
        f"{prefix}_plane_max_mm": 1e3 * float(e_t.max()),
        f"{prefix}_normal_mean_mm": 1e3 * float(e_n.mean()),
        f"{prefix}_normal_max_abs_mm": 1e3 * float(np.abs(e_n).max()),
        f"{prefix}_3d_rms_mm": 1e3 * float(np.sqrt(np.mean(e_3**2))),
        f"{prefix}_3d_max_mm": 1e3 * float(e_3.max()),
    }
