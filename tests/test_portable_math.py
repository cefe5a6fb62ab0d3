"""Functions whose bits are the same on every CPU code path (inkmotion.portable_math), and
the fit's Adam update written with them: accurate, differentiable, and the same bits
under torch's scalar kernels (ATEN_CPU_CAPABILITY=default) as under its vector ones."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import pytest
import torch

from inkmotion.portable_math import expm1, log1p, planar_norm


@pytest.fixture(params=[torch.float32, torch.float64], ids=["f32", "f64"])
def dtype(request: pytest.FixtureRequest) -> torch.dtype:
    return request.param


def _ulps(ours: torch.Tensor, exact: torch.Tensor, dtype: torch.dtype) -> float:
    """The largest error of ``ours`` against ``exact`` (float64) in units of ``dtype``'s
    epsilon, relative."""
    ok = torch.isfinite(exact) & (exact != 0) & (exact.abs() < torch.finfo(dtype).max)
    rel = ((ours.double() - exact) / exact.abs())[ok].abs().max()
    return float(rel) / torch.finfo(dtype).eps


def test_expm1_and_log1p_are_as_accurate_as_torchs_to_two_ulps(dtype: torch.dtype) -> None:
    small = torch.logspace(-30, 1.9, 3000, dtype=dtype)
    x = torch.cat([small, -small])
    assert _ulps(expm1(x), torch.expm1(x.double()), dtype) <= 2.0
    y = torch.cat([torch.logspace(-30, 6, 3000, dtype=dtype),
                   -torch.logspace(-30, -0.0001, 3000, dtype=dtype)])
    assert _ulps(log1p(y), torch.log1p(y.double()), dtype) <= 2.0


def test_the_edges_are_the_library_functions(dtype: torch.dtype) -> None:
    edges = torch.tensor([0.0, -0.0, math.inf, -math.inf], dtype=dtype)
    assert expm1(edges).tolist() == [0.0, 0.0, math.inf, -1.0]
    assert log1p(torch.tensor([0.0, -1.0, math.inf], dtype=dtype)).tolist() == [
        0.0, -math.inf, math.inf]
    assert bool(log1p(torch.tensor([-2.0], dtype=dtype)).isnan())


def test_gradients_match_their_derivatives() -> None:
    x = torch.tensor([1e-7, 0.01, 0.3, 2.0, -0.5], dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(expm1, (x,))
    assert torch.autograd.gradcheck(log1p, (x,))
    v = torch.randn(4, 3, 2, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(planar_norm, (v,))
    assert torch.allclose(planar_norm(v), v.norm(dim=-1))


def test_the_length_of_a_zero_vector_has_a_zero_gradient() -> None:
    """A stationary sample (a dot, a pause) must not send NaN into a fit's gradient."""
    v = torch.tensor([[0.0, 0.0], [3.0, 4.0]], requires_grad=True)
    planar_norm(v).sum().backward()
    assert planar_norm(v).tolist() == [0.0, 5.0]
    assert v.grad.tolist() == [[0.0, 0.0], [0.6000000238418579, 0.800000011920929]]


_SCRIPT = """
import hashlib, torch
from inkmotion.fitting.optimise import Adam
from inkmotion.portable_math import expm1, log1p, planar_norm

def wavy(n, k=0):  # numbers from exact arithmetic (randn's own kernels differ by path)
    i = torch.arange(n, dtype=torch.float64)
    return (((i * 7919 + k * 104729) % 997) / 97.0 - 5.0).float()

x = wavy(4096)
v = torch.stack((wavy(4096, 1), wavy(4096, 2)), 1) * 100
out = [expm1(x), log1p(x.abs()), planar_norm(v)]
params = [wavy(26, 3).reshape(13, 2).requires_grad_(True), wavy(11, 4).requires_grad_(True)]
adam = Adam([(params[0], 1.0), (params[1], 0.05)])
for k in range(50):
    for j, p in enumerate(params):
        p.grad = wavy(p.numel(), 10 * k + j).reshape(p.shape) * 10.0 ** (k % 5 - 2)
    adam.step(0.3 + 0.7 * (k % 7) / 7)
out += [p.detach() for p in params]
print(torch.backends.cpu.get_cpu_capability(),
      [hashlib.sha256(t.numpy().tobytes()).hexdigest()[:16] for t in out])
"""


def test_the_same_bits_on_the_scalar_code_path() -> None:
    """torch's expm1, log1p, vector_norm, lerp and addcmul round differently on the
    scalar path than on AVX2/AVX-512 (a fused multiply-add); these do not."""
    runs = {}
    for path in (None, "default"):
        env = {k: v for k, v in os.environ.items() if k != "ATEN_CPU_CAPABILITY"}
        if path is not None:
            env["ATEN_CPU_CAPABILITY"] = path
        out = subprocess.run([sys.executable, "-c", _SCRIPT], env=env, check=True,
                             capture_output=True, text=True).stdout.split(" ", 1)
        runs[out[0]] = out[1]
    if len(runs) < 2:
        pytest.skip("this CPU runs torch's scalar code path already")
    assert len(set(runs.values())) == 1, runs
