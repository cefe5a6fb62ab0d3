"""Multi-scale MSE: zero at identity, ordering, gradients, level count."""


import pytest
import torch

import inkmotion
from inkmotion.image_losses.multiscale_mse import (
    default_levels,
    multiscale_mse,
    prepare_multiscale_mse,
    pyramid,
)
from inkmotion.plugin_host.protocols import Reference


def _disc(h: int, w: int, cx: float | torch.Tensor, cy: float, r: float = 6.0,
          device: torch.device | str = "cpu") -> torch.Tensor:
    y, x = torch.meshgrid(torch.arange(h, dtype=torch.float64, device=device),
                          torch.arange(w, dtype=torch.float64, device=device), indexing="ij")
    return torch.sigmoid(2.0 * (r - torch.hypot(x - cx, y - cy)))


def test_zero_for_identical(device: torch.device) -> None:
    a = _disc(64, 48, 20, 20, device=device)
    assert float(multiscale_mse(a, a.clone())) == 0.0
    loss = inkmotion.plugin("image-loss", "mse").prepare(a)
    assert float(loss(a.clone())) == 0.0


def test_positive_and_decreasing_as_images_approach(device: torch.device) -> None:
    target = _disc(64, 64, 40, 40, device=device)
    loss = inkmotion.plugin("image-loss", "mse").prepare(target)
    values = [float(loss(_disc(64, 64, 40 - s, 40 - s, device=device)))
              for s in (24, 16, 8, 4, 1)]
    assert all(v > 0 for v in values)
    assert values == sorted(values, reverse=True)
    # the coarse levels still see discs that do not overlap at full resolution
    far = _disc(64, 64, 10, 10, device=device)
    assert float(loss(far)) > float(torch.nn.functional.mse_loss(far, target))


def test_gradient_flows(device: torch.device) -> None:
    target = _disc(40, 40, 25, 20, device=device)
    cx = torch.tensor(10.3, dtype=torch.float64, device=device, requires_grad=True)
    loss = inkmotion.plugin("image-loss", "mse").prepare(target)
    value = loss(_disc(40, 40, cx, 20.5, device=device))
    value.backward()
    assert cx.grad is not None and float(cx.grad) < 0  # moving right reduces the loss
    a = torch.rand(1, 1, 12, 12, dtype=torch.float64).squeeze().requires_grad_()
    b = torch.rand(12, 12, dtype=torch.float64)
    torch.autograd.gradcheck(lambda x: multiscale_mse(x, b, 3), (a,))


@pytest.mark.parametrize(("h", "w", "n"), [(350, 350, 6), (350, 200, 6), (64, 64, 4),
                                           (8, 8, 1), (3, 5, 1)])
def test_number_of_levels(h: int, w: int, n: int) -> None:
    assert default_levels(h, w) == n
    levels = pyramid(torch.zeros(h, w), n)
    assert len(levels) == n
    assert levels[-1].shape[-1] == -(-w // 2 ** (n - 1))


def test_dtype_follows_input(device: torch.device) -> None:
    t = torch.rand(32, 32, device=device)
    loss = inkmotion.plugin("image-loss", "mse").prepare(t)
    assert loss(torch.rand(32, 32, dtype=torch.float64, device=device)).dtype == torch.float64
    assert multiscale_mse(t, t, 2).dtype == torch.float32


def test_matrix_operators_equal_convolution_pyramid(device: torch.device) -> None:
    """prepare()'s fast separable operators compute exactly the blur-and-pool pyramid."""
    g = torch.Generator().manual_seed(0)
    target = (torch.rand(37, 61, generator=g, dtype=torch.float64) > 0.8).double().to(device)
    image = torch.rand(37, 61, generator=g, dtype=torch.float64).to(device)
    fast = prepare_multiscale_mse(target)(image)
    torch.testing.assert_close(fast, multiscale_mse(image, target))


def test_plugin_takes_a_reference_and_levels() -> None:
    target = _disc(64, 64, 30, 30)
    plugin = inkmotion.plugin("image-loss", "mse")
    image = _disc(64, 64, 25, 30)
    torch.testing.assert_close(plugin.prepare(Reference(image=target), levels=2)(image),
                               multiscale_mse(image, target, 2))


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_gathered_levels_are_the_strided_levels_bit_for_bit(device: torch.device,
                                                            dtype: torch.dtype) -> None:
    """A small level goes down (and its gradient up) by gathers: the same products added in
    the same order as the strided form, so the same bits, at every size, odd or even, along
    either axis, whatever the other axis holds."""
    from inkmotion.image_losses import multiscale_mse as mse

    g = torch.Generator().manual_seed(1)
    for n in [*range(3, 40), 61, 88, 121, 175]:
        for other in (1, 7):
            for dim in (-2, -1):
                shape = (other, n) if dim == -1 else (n, other)
                x = torch.randn(shape, generator=g, dtype=torch.float64).to(device, dtype)
                down = mse._down_forward(x, dim)
                assert torch.equal(mse._down_gathered(x, dim), down), (n, other, dim)
                grad = torch.randn(down.shape, generator=g, dtype=torch.float64).to(
                    device, dtype)
                assert torch.equal(mse._up_gathered(grad, n, dim),
                                   mse._down_backward(grad, n, dim)), (n, other, dim)


def test_the_loss_and_its_gradient_do_not_depend_on_which_form_a_level_takes(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from inkmotion.image_losses import multiscale_mse as mse

    g = torch.Generator().manual_seed(2)
    target = (torch.rand(90, 67, generator=g) > 0.7).float()
    image = torch.rand(90, 67, generator=g)

    def loss_and_grad() -> tuple[torch.Tensor, torch.Tensor]:
        x = image.clone().requires_grad_(True)
        value = prepare_multiscale_mse(target)(x)
        value.backward()
        return value.detach(), x.grad

    monkeypatch.setattr(mse, "GATHER_BELOW", 0)
    monkeypatch.setattr(mse, "UP_GATHER_BELOW", 0)
    strided = loss_and_grad()
    monkeypatch.setattr(mse, "GATHER_BELOW", 10**9)
    monkeypatch.setattr(mse, "UP_GATHER_BELOW", 10**9)
    gathered = loss_and_grad()
    assert torch.equal(strided[0], gathered[0]) and torch.equal(strided[1], gathered[1])
