"""The paper's multi-scale mean squared error (eq. "mse"), the "mse" image loss.

    L_I = Σ_{s ∈ S} MSE(I_s, Î_s)

I_0 is the image itself; I_{s+1} = downscale_½(blur_σ=1(I_s)): a 5×5 separable Gaussian
(σ = 1 px, replicate padding) followed by 2×2 average pooling (a partial last window is
averaged over the pixels it holds). The default number of levels is ⌊log2(size)⌋ − 2
(size = the longer side, at least 1 level), so the coarsest level is about 4–8 px across;
for a 350-px canvas that is 6 levels (350 → 175 → 88 → 44 → 22 → 11). Coarse levels give a
gradient towards ink that is far away, which improves convergence (paper, Results).

Everything is a plain torch op: differentiable, on the inputs' device and dtype.

Determinism. :func:`prepare_multiscale_mse` computes the levels of a fit's rendering with
elementwise torch ops only — the 5-tap blur as five scaled, shifted copies added in a fixed
order, the pooling as the mean of the even and odd samples — no matrix product and no
convolution. Elementwise IEEE arithmetic gives the same bits whatever the thread count
and whatever the instruction set its kernels were built for, so the loss's gradient (what
the optimiser sees) is the same under 1, 2 or 4 threads and under other BLAS or oneDNN code
paths (``MKL_CBWR``). The dense operators it replaced (two matrix products per level)
changed their last bits with the thread count and the MKL code path, which a few hundred
Adam steps carried into different plans. (The batched loss of several drawings,
:func:`stack_multiscale_mse`, still uses matrix products: a batch agrees with its drawings
alone up to float round-off.)
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch
import torch.nn.functional as F

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


def pyramid_operators(n: int, levels: int, dtype: torch.dtype,
                      device: torch.device | str | None = None) -> list[torch.Tensor]:
    """1-D operators [P_0 = I, P_1, …] (n_s, n) with level_s = P_s · signal along one axis.

    Built by blurring (replicate padding) and 2-pooling (ceil mode) the identity, exactly the
    steps :func:`pyramid` takes along each axis.
    """
    k = _gaussian_1d(dtype, torch.device(device) if device is not None else None)
    r = KERNEL_SIZE // 2
    op = torch.eye(n, dtype=dtype, device=device)  # rows: output samples
    ops = [op]
    for _ in range(levels - 1):
        x = op.t().unsqueeze(1)  # (n, 1, n_s): each input basis vector as a 1-D signal
        x = F.conv1d(F.pad(x, (r, r), mode="replicate"), k.view(1, 1, -1))
        x = F.avg_pool1d(x, kernel_size=2, ceil_mode=True)
        op = x.squeeze(1).t().contiguous()  # (n_{s+1}, n)
        ops.append(op)
    return ops


def _down_last(x: torch.Tensor) -> torch.Tensor:
    """One level down along the last axis (n → ⌈n/2⌉): the 5-tap Gaussian with replicate
    padding, then the mean of each pair (a lone last sample kept), exactly :func:`pyramid`
    along that axis; elementwise ops in a fixed order (module docstring: determinism)."""
    n = x.shape[-1]
    k = _gaussian_1d(torch.float64, torch.device("cpu")).tolist()
    r = KERNEL_SIZE // 2
    padded = torch.cat([x[..., :1]] * r + [x] + [x[..., -1:]] * r, dim=-1)
    blurred = padded[..., 0:n] * k[0]
    for j in range(1, KERNEL_SIZE):
        blurred = blurred + padded[..., j:j + n] * k[j]
    if n % 2:  # ceil mode: the last window holds one sample, its own mean
        blurred = torch.cat((blurred, blurred[..., -1:]), dim=-1)
    return (blurred[..., 0::2] + blurred[..., 1::2]) * 0.5


def _down(image: torch.Tensor) -> torch.Tensor:
    """One pyramid level down along both axes of ``image`` (..., H, W)."""
    return _down_last(_down_last(image).transpose(-1, -2)).transpose(-1, -2)


def prepare_multiscale_mse(
    target: torch.Tensor, levels: int | None = None
) -> Callable[[torch.Tensor], torch.Tensor]:
    """``loss(rendered (H, W)) -> scalar``: Σ_s MSE(rendered_s, target_s) against ``target``
    (H, W), whose levels are computed once; ``levels`` defaults to :func:`default_levels`.
    Its gradient is bitwise the same under any thread count and code path (module
    docstring)."""
    h, w = target.shape[-2:]
    if levels is None:
        levels = default_levels(h, w)
    assert levels >= 1, levels
    target = target.detach().reshape(h, w)

    def levels_of(image: torch.Tensor) -> list[torch.Tensor]:
        out = [image]
        for _ in range(levels - 1):
            out.append(_down(out[-1]))
        return out

    with torch.no_grad():
        target_levels = levels_of(target)

    def loss(rendered: torch.Tensor) -> torch.Tensor:
        assert rendered.shape[-2:] == (h, w), (rendered.shape, target.shape)
        image = rendered.reshape(h, w)
        total = image.new_zeros(())
        for x, y in zip(levels_of(image), target_levels, strict=True):
            total = total + F.mse_loss(x, y.to(x.dtype))
        return total

    loss.target, loss.levels = target, levels  # type: ignore[attr-defined]
    loss.stack = stack_multiscale_mse  # type: ignore[attr-defined]  # a batched fit's
    return loss


def stack_multiscale_mse(losses: list[Callable], height: int, width: int
                         ) -> Callable[[torch.Tensor], torch.Tensor]:
    """The losses of :func:`prepare_multiscale_mse` of several drawings as one:
    ``loss(rendered (B, H, W)) -> (B,)``, drawing b's own loss of its image (its canvas
    h_b × w_b in the top-left corner of an H × W page, zero elsewhere), up to float
    round-off.

    The levels are computed one from the next, I_{s+1} = A_s · I_s · B_sᵀ, with each
    drawing's one-step operators (blur and 2-pool of its own sizes, so its edges are its
    own) zero-padded into common shapes: two batched matrix products per level for all
    the drawings, about 2/3 of the products of the single loss's stacked operators (the
    same linear map). The padding adds exact zeros to every product and squared error;
    each error sum is divided by the drawing's own pixel count at that level. (Measured
    here on 9 tags: the blur-and-pool chain on the pages with each drawing's edge
    replicated by gathers, or the one-step operators applied as gathered bands of ≤ 6
    weights, give the same values with far fewer products but ran 1.3× slower than MKL's
    dense products.)"""
    targets = [fn.target for fn in losses]  # type: ignore[attr-defined]
    own_levels = [int(fn.levels) for fn in losses]  # type: ignore[attr-defined]
    levels = max(own_levels)
    dtype, device = targets[0].dtype, targets[0].device
    n = len(targets)
    shapes = [(height, width)]  # the pages' level sizes
    for _ in range(levels - 1):
        h, w = shapes[-1]
        shapes.append(((h + 1) // 2, (w + 1) // 2))
    rows_ops = [torch.zeros(n, shapes[s + 1][0], shapes[s][0], dtype=dtype, device=device)
                for s in range(levels - 1)]
    cols_ops = [torch.zeros(n, shapes[s][1], shapes[s + 1][1], dtype=dtype, device=device)
                for s in range(levels - 1)]
    counts = torch.ones(levels, n, dtype=dtype, device=device)
    weights = torch.zeros(levels, n, dtype=dtype, device=device)  # 0: a level it lacks
    page = torch.zeros(n, height, width, dtype=dtype, device=device)
    for b, (t, k) in enumerate(zip(targets, own_levels, strict=True)):
        h, w = t.shape
        page[b, :h, :w] = t
        for s in range(k):
            counts[s, b], weights[s, b] = h * w, 1.0
            if s + 1 < k:
                down_h = pyramid_operators(h, 2, dtype, device)[1]  # (h', h)
                down_w = pyramid_operators(w, 2, dtype, device)[1]  # (w', w)
                rows_ops[s][b, :down_h.shape[0], :h] = down_h
                cols_ops[s][b, :w, :down_w.shape[0]] = down_w.t()
                h, w = down_h.shape[0], down_w.shape[0]

    def levels_of(image: torch.Tensor) -> list[torch.Tensor]:
        out = [image]
        for a, c in zip(rows_ops, cols_ops, strict=True):
            out.append(torch.bmm(torch.bmm(a.to(image.dtype), out[-1]), c.to(image.dtype)))
        return out

    with torch.no_grad():
        target_levels = levels_of(page)

    def loss(rendered: torch.Tensor) -> torch.Tensor:
        assert rendered.shape == (n, height, width), (rendered.shape, (n, height, width))
        total = rendered.new_zeros(n)
        for k, (x, y) in enumerate(zip(levels_of(rendered), target_levels, strict=True)):
            d = x - y.to(x.dtype)
            total = total + weights[k].to(x.dtype) * (d * d).sum((1, 2)) / counts[k].to(
                x.dtype)
        return total

    return loss
