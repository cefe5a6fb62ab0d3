"""Elementwise functions that give the same bits on every CPU code path.

torch picks a kernel per CPU (``ATEN_CPU_CAPABILITY``: AVX-512, AVX2, or the scalar code
of a CPU without them), and some of its functions round differently from one kernel to
another: on x86, ``expm1``, ``log1p`` and ``linalg.vector_norm`` among those a fit's step
uses (found by hashing every op's inputs and outputs of a fit's steps under both paths).
``exp``, ``log``, ``sqrt`` and the four basic operations give the same bits on every path,
so these functions are written with them alone: a fit then takes the same steps, and
makes the same plan, on any x86 CPU (issue 32, item 2).

The forms are W. Kahan's (*Hewlett-Packard HP-15C Advanced Functions Handbook*, 1982):
with u = e^x, expm1(x) = (u − 1)·x / ln u, and with u = 1 + x, log1p(x) = ln u · x / (u − 1),
each x itself where u rounds to 1. They are as accurate as the library functions to a few
ulps, and differentiable (the branch where u rounds to 1 is the identity).
"""

from __future__ import annotations

import torch

from inkmotion.scalar_tensors import scalar_tensors


def expm1(x: torch.Tensor) -> torch.Tensor:
    """e^x − 1, accurate near 0 (Kahan: (u − 1)·x / ln u with u = e^x; x where u = 1)."""
    one, zero = scalar_tensors(x, 1.0, 0.0)
    u = torch.exp(x)
    less = u - one
    log_u = torch.log(u)
    flat = less == zero  # u rounded to 1: e^x − 1 is x to working precision
    safe = torch.where(flat, one, log_u)
    out = torch.where(flat, x, less * x / safe)
    return torch.where(u.isinf() | (u == zero), less, out)  # e^x − 1 = ∞, or −1 at x = −∞


def log1p(x: torch.Tensor) -> torch.Tensor:
    """ln(1 + x), accurate near 0 (Kahan: ln u · x / (u − 1) with u = 1 + x; x where
    u = 1)."""
    one, zero = scalar_tensors(x, 1.0, 0.0)
    u = one + x
    less = u - one
    flat = less == zero
    safe = torch.where(flat, one, less)
    out = torch.where(flat, x, torch.log(u) * x / safe)
    return torch.where(u.isinf(), u, out)


def planar_norm(v: torch.Tensor) -> torch.Tensor:
    """√(x² + y²) of the last axis's first two entries (..., ≥2) → (...): the Euclidean
    length of a plane vector, as an elementwise sum of two squares; at the zero vector
    its gradient is 0, as ``torch.linalg.vector_norm``'s (not √'s infinite slope)."""
    x, y = v[..., 0], v[..., 1]
    one, zero = scalar_tensors(v, 1.0, 0.0)
    squares = x * x + y * y
    moving = squares > zero
    return torch.sqrt(torch.where(moving, squares, one)) * moving
