"""Image loss "mse": the paper's multi-scale mean squared error (eq. "mse").

    L_I = Σ_{s ∈ S} MSE(I_s, Î_s)

I_0 is the image itself; I_{s+1} = downscale_½(blur_σ=1(I_s)): a 5×5 separable Gaussian
(σ = 1 px, replicate padding) followed by 2×2 average pooling (a partial last window is
averaged over the pixels it holds). The default number of levels is ⌊log2(size)⌋ − 2
(size = the longer side, at least 1 level), so the coarsest level is about 4–8 px across;
for a 350-px canvas that is 6 levels (350 → 175 → 88 → 44 → 22 → 11). Coarse levels give a
gradient towards ink that is far away, which improves convergence (paper, Results).

Everything is a plain torch op: differentiable, on the inputs' device and dtype.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch
import torch.nn.functional as F

from inkmotion.plugin_host import hookimpl

BLUR_SIGMA = 1.0
KERNEL_SIZE = 5


def default_levels(height: int, width: int) -> int:
    """⌊log2(max(H, W))⌋ − 2, at least 1."""
    return max(1, int(math.floor(math.log2(max(height, width, 1)))) - 2)


def _gaussian_1d(dtype: torch.dtype, device: torch.device) -> torch.Tensor:
    """Normalised 1-D Gaussian (KERNEL_SIZE,) with σ = BLUR_SIGMA."""
    x = torch.arange(KERNEL_SIZE, dtype=dtype, device=device) - (KERNEL_SIZE - 1) / 2
    k = torch.exp(-0.5 * (x / BLUR_SIGMA) ** 2)
    return k / k.sum()


def blur(x: torch.Tensor) -> torch.Tensor:
    """Separable Gaussian blur (σ = 1, 5×5, replicate padding) of x (N, 1, H, W)."""
    k = _gaussian_1d(x.dtype, x.device)
    r = KERNEL_SIZE // 2
    x = F.conv2d(F.pad(x, (r, r, 0, 0), mode="replicate"), k.view(1, 1, 1, -1))
    return F.conv2d(F.pad(x, (0, 0, r, r), mode="replicate"), k.view(1, 1, -1, 1))


def pyramid(image: torch.Tensor, levels: int) -> list[torch.Tensor]:
    """[I_0, …, I_{levels−1}] of an image (..., H, W); each level (N, 1, H_s, W_s)."""
    h, w = image.shape[-2:]
    x = image.reshape(-1, 1, h, w)
    out = [x]
    for _ in range(levels - 1):
        x = F.avg_pool2d(blur(x), kernel_size=2, ceil_mode=True)
        out.append(x)
    return out


def multiscale_mse(a: torch.Tensor, b: torch.Tensor, levels: int | None = None) -> torch.Tensor:
    """Σ_s MSE(a_s, b_s) over the blur-and-halve pyramids of two images (..., H, W)."""
    assert a.shape == b.shape, (a.shape, b.shape)
    if levels is None:
        levels = default_levels(*a.shape[-2:])
    return sum(
        (F.mse_loss(x, y) for x, y in zip(pyramid(a, levels), pyramid(b, levels), strict=True)),
        start=a.new_zeros(()),
    )


class MultiscaleMse:
    """The multi-scale MSE against a fixed target, its pyramid computed once."""

    name = "mse"
    description = (
        "Multi-scale MSE (paper eq. mse): Gaussian blur σ=1 and ½ downscale per level, "
        "⌊log2(size)⌋−2 levels, summed."
    )

    def prepare(
        self, target: torch.Tensor, levels: int | None = None
    ) -> Callable[[torch.Tensor], torch.Tensor]:
        """``loss(rendered (H, W)) -> scalar`` against ``target`` (H, W)."""
        if levels is None:
            levels = default_levels(*target.shape[-2:])
        assert levels >= 1, levels
        with torch.no_grad():
            target_levels = pyramid(target.detach(), levels)

        def loss(rendered: torch.Tensor) -> torch.Tensor:
            assert rendered.shape[-2:] == target.shape[-2:], (rendered.shape, target.shape)
            total = rendered.new_zeros(())
            for x, y in zip(pyramid(rendered, levels), target_levels, strict=True):
                total = total + F.mse_loss(x, y.to(dtype=x.dtype, device=x.device))
            return total

        return loss


@hookimpl
def inkmotion_image_losses() -> list:
    return [MultiscaleMse()]
