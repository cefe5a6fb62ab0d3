"""Numbers as cached 0-d tensors (inkmotion.scalar_tensors): the same bits as the numbers
themselves in the ops a fit's step takes, made once per dtype and device."""

from __future__ import annotations

import math

import pytest
import torch

from inkmotion.scalar_tensors import scalar_tensors

NUMBERS = (0.5, -0.5, 1.0, 3.0, 1e-12, math.sqrt(2.0 * math.pi), 2.0 * math.pi, 45.0, 1 / 3)


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_an_op_with_the_tensor_gives_the_bits_of_the_op_with_the_number(dtype) -> None:
    g = torch.Generator().manual_seed(3)
    x = (torch.randn(4099, generator=g, dtype=torch.float64) * 10.0).to(dtype)
    for number, tensor in zip(NUMBERS, scalar_tensors(x, *NUMBERS), strict=True):
        assert tensor.dtype == dtype and tensor.dim() == 0
        for op in (torch.mul, torch.add, torch.sub, torch.div):
            assert torch.equal(op(x, number), op(x, tensor)), (op, number)
            assert torch.equal(op(number, x) if op is not torch.sub else number - x,
                               op(tensor, x)), (op, number)
        assert torch.equal(torch.where(x > 0, number, x), torch.where(x > 0, tensor, x))


def test_the_gradient_through_the_tensor_is_the_gradient_through_the_number() -> None:
    g = torch.Generator().manual_seed(4)
    x = torch.randn(257, generator=g)
    grads = []
    for c in (0.37, scalar_tensors(x, 0.37)[0]):
        leaf = x.clone().requires_grad_(True)
        (torch.sin(leaf * c) / c).sum().backward()
        grads.append(leaf.grad)
    assert torch.equal(*grads)


def test_they_are_made_once_per_dtype_and_device() -> None:
    x32, x64 = torch.zeros(2), torch.zeros(2, dtype=torch.float64)
    assert scalar_tensors(x32, 0.25, 4.0)[1] is scalar_tensors(x32, 0.25, 4.0)[1]
    assert scalar_tensors(x64, 0.25)[0].dtype == torch.float64
    assert float(scalar_tensors(x32, 0.1)[0]) == float(torch.tensor(0.1, dtype=torch.float32))
