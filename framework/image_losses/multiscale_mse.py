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
elementwise torch ops only — the 5-tap blur and the pair mean folded into one stride-2
filter of 6 taps, applied as six scaled, shifted copies added in a fixed order — no matrix
product and no convolution (a small level gathers its six taps at once and adds the same
products in the same order, :data:`GATHER_BELOW`: the same bits in fewer ops).
Elementwise IEEE arithmetic gives the same bits whatever the thread count and whatever
the instruction set its kernels were built for, so the loss's gradient (what the
optimiser sees) is the same under 1, 2 or 4 threads and under other BLAS or oneDNN code
paths (``MKL_CBWR``). The dense operators it replaced (two matrix
products per level) changed their last bits with the thread count and the MKL code path,
which a few hundred Adam steps carried into different plans. (The batched loss of several
drawings, :func:`stack_multiscale_mse`, still uses matrix products: a batch agrees with
its drawings alone up to float round-off.)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

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


@functools.cache
def _taps() -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The 5 blur weights k (:func:`_gaussian_1d` in float64, as Python floats), and the 6
    weights of blur-then-pair-mean folded into one stride-2 filter: ½·(k0, k0+k1, k1+k2,
    k2+k3, k3+k4, k4). Read once per process: no tensor is read inside a step."""
    k = tuple(_gaussian_1d(torch.float64, torch.device("cpu")).tolist())
    return k, tuple(0.5 * a for a in (k[0], k[0] + k[1], k[1] + k[2], k[2] + k[3],
                                      k[3] + k[4], k[4]))


@functools.cache
def _tap_tensors(dtype: torch.dtype, device: torch.device
                 ) -> tuple[tuple[torch.Tensor, ...], tuple[torch.Tensor, ...]]:
    """:func:`_taps` as 0-d tensors of ``dtype`` on ``device``, made once: a product with
    one rounds the weight to ``dtype`` as a Python float would, the same bits, without
    wrapping the number into a tensor on every call (about 1 µs an op here)."""
    k, folded = _taps()
    as_tensors = lambda w: torch.tensor(w, dtype=torch.float64).to(  # noqa: E731
        device=device, dtype=dtype).unbind(0)
    return as_tensors(k), as_tensors(folded)


def _down_forward(image: torch.Tensor, dim: int) -> torch.Tensor:
    """One level down along ``dim`` (-1 or -2) of ``image`` (..., H, W), n → ⌈n/2⌉: the
    5-tap Gaussian with replicate padding, then the mean of each pair of samples (a lone
    last sample kept: ceil mode), as :func:`pyramid` does along that axis, folded into
    one stride-2 filter of 6 taps; elementwise ops in a fixed order (module docstring:
    determinism)."""
    n = image.shape[dim]
    half = n // 2
    k, folded = _tap_tensors(image.dtype, image.device)
    r = KERNEL_SIZE // 2
    first, last = image.narrow(dim, 0, 1), image.narrow(dim, n - 1, 1)
    padded = torch.cat([first] * r + [image] + [last] * (r + 1), dim=dim)  # n + 5
    lead = (slice(None),) * (padded.dim() + dim)  # the axes before ``dim``
    out = padded[(*lead, slice(0, 2 * half, 2))] * folded[0]
    for j in range(1, 6):
        out.add_(padded[(*lead, slice(j, j + 2 * half, 2))] * folded[j])
    if n % 2:  # the last window holds the one blurred sample n − 1
        tail = padded.narrow(dim, n - 1, 1) * k[0]
        for j in range(1, KERNEL_SIZE):
            tail.add_(padded.narrow(dim, n - 1 + j, 1) * k[j])
        out = torch.cat((out, tail), dim=dim)
    return out


def _down_backward(grad: torch.Tensor, n: int, dim: int) -> torch.Tensor:
    """The adjoint of :func:`_down_forward` (its exact transpose) applied to ``grad``: each
    output's gradient added back to the samples it read, with their weights, in a fixed
    order into one buffer (no autograd graph of slices, each of which would allocate and
    zero a full-size gradient; each add in place into a view of it, never a slice
    assignment, which would copy the slice onto itself once more)."""
    half = n // 2
    k, folded = _tap_tensors(grad.dtype, grad.device)
    r = KERNEL_SIZE // 2
    shape = list(grad.shape)
    shape[dim] = n + 2 * r + 1
    padded = grad.new_zeros(shape)
    lead = (slice(None),) * (grad.dim() + dim)
    body = grad.narrow(dim, 0, half)
    for j in range(6):
        padded[(*lead, slice(j, j + 2 * half, 2))].add_(body * folded[j])
    if n % 2:
        tail = grad.narrow(dim, half, 1)
        for j in range(KERNEL_SIZE):
            padded.narrow(dim, n - 1 + j, 1).add_(tail * k[j])
    # the body of the buffer, its edges folded back in place (they read only the padding:
    # no copy, the same values)
    out = padded.narrow(dim, r, n)
    out.narrow(dim, 0, 1).add_(padded.narrow(dim, 0, 1)).add_(padded.narrow(dim, 1, 1))
    end = padded.narrow(dim, r + n, r + 1)
    for j in range(r + 1):
        out.narrow(dim, n - 1, 1).add_(end.narrow(dim, j, 1))
    return out


#: an image of fewer samples than this goes down one level by the gathered form
#: (:func:`_down_gathered`), and a gradient of fewer than :data:`UP_GATHER_BELOW` comes
#: back up by it (:func:`_up_gathered`): the same bits in about a third of the ops, which
#: is what a small level costs; a large level's strided form moves less memory. (Measured
#: on a 350 × 242 canvas, one thread: the loss and its gradient 2.05 → 1.73 ms.)
GATHER_BELOW = 30_000
UP_GATHER_BELOW = 3_000


@functools.lru_cache(maxsize=512)
def _gather_plan(n: int, dtype: torch.dtype, device: torch.device
                 ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """The taps of :func:`_down_forward` along an axis of n ≥ 3 samples as gathers, made
    once per size: ``index`` (6·m,) the sample each tap reads (replicate padding as a
    clamped index; m = ⌈n/2⌉ outputs, tap-major), ``weight`` (6, m) its weight (a lone last
    window: the 5 blur weights and a 6th of 0: adding +0 changes no value, at most the
    sign of a zero); for the adjoint, ``sources`` (4, n + 5): per padded sample, the products that
    :func:`_down_backward` adds into it, in its order (6·m: none), and ``folds`` (4, n):
    per sample, the padded samples it sums, in its order (n + 5: none)."""
    k, folded = _taps()
    r = KERNEL_SIZE // 2
    half, m = n // 2, (n + 1) // 2
    index = [[min(max(2 * i + j - r, 0), n - 1) for i in range(half)] for j in range(6)]
    weight = [[folded[j]] * half for j in range(6)]
    if n % 2:
        for j in range(6):
            index[j].append(min(max(n - 1 + j - r, 0), n - 1))
            weight[j].append(k[j] if j < KERNEL_SIZE else 0.0)
    size = n + 2 * r + 1
    sources = [[] for _ in range(size)]
    for j in range(6):  # the body's taps in order, then the last window's
        for i in range(half):
            sources[2 * i + j].append(j * m + i)
    if n % 2:
        for j in range(KERNEL_SIZE):
            sources[n - 1 + j].append(j * m + half)
    folds = [[x + r] for x in range(n)]
    folds[0] += [0, 1]
    folds[n - 1] += [r + n + j for j in range(r + 1)]
    assert n >= 3 and max(map(len, sources)) <= 4 and max(map(len, folds)) <= 4, n

    def table(rows: list[list[int]], none: int) -> torch.Tensor:  # (4, rows), term-major
        return torch.tensor([row + [none] * (4 - len(row)) for row in rows],
                            device=device).t().contiguous()

    return (torch.tensor(index, device=device).reshape(-1),
            torch.tensor(weight, dtype=torch.float64).to(device=device, dtype=dtype),
            table(sources, 6 * m), table(folds, size))


def _sum_in_order(terms: list[torch.Tensor]) -> torch.Tensor:
    """((t0 + t1) + t2) + … : one new tensor, then in place."""
    out = terms[0] + terms[1]
    for t in terms[2:]:
        out.add_(t)
    return out


def _gathered_sums(x: torch.Tensor, dim: int, table: torch.Tensor) -> torch.Tensor:
    """Along ``dim``: out[row] = ((x[t0] + x[t1]) + x[t2]) + x[t3] for each row of
    ``table`` (4, rows), term-major; an index of x's length along ``dim`` reads a 0."""
    pad = [0, 0] * (-dim - 1) + [0, 1]  # one zero sample after the last along ``dim``
    picked = F.pad(x, pad).index_select(dim, table.reshape(-1))
    return _sum_in_order(list(picked.unflatten(dim, table.shape).unbind(dim - 1)))


def _split_shape(x: torch.Tensor, dim: int, weight: torch.Tensor) -> list[int]:
    """The shape that lays ``weight`` (6, m) on the taps axis split at ``dim`` of a tensor
    of x's rank + 1 (ones elsewhere)."""
    shape = [1] * (x.dim() + 1)
    shape[dim - 1], shape[dim] = weight.shape
    return shape


def _down_gathered(image: torch.Tensor, dim: int) -> torch.Tensor:
    """:func:`_down_forward` as one gather of the six taps, one product and five sums: the
    same products added in the same order, so the same bits (n ≥ 3)."""
    index, weight, _, _ = _gather_plan(image.shape[dim], image.dtype, image.device)
    taps = image.index_select(dim, index).unflatten(dim, weight.shape)  # (…, 6, m, …)
    products = taps * weight.reshape(_split_shape(image, dim, weight))
    return _sum_in_order(list(products.unbind(dim - 1)))


def _up_gathered(grad: torch.Tensor, n: int, dim: int) -> torch.Tensor:
    """:func:`_down_backward` by gathers: each output's six weighted gradients, then per
    padded sample the ones it receives (:func:`_gather_plan`'s ``sources``), then the
    replicated edges folded back (``folds``), each sum in :func:`_down_backward`'s order:
    the same bits (n ≥ 3)."""
    _, weight, sources, folds = _gather_plan(n, grad.dtype, grad.device)
    products = grad.unsqueeze(dim - 1) * weight.reshape(_split_shape(grad, dim, weight))
    padded = _gathered_sums(products.flatten(dim - 1, dim), dim, sources)
    return _gathered_sums(padded, dim, folds)


def _down(image: torch.Tensor, dim: int) -> torch.Tensor:
    """One pyramid level down along ``dim`` (module docstring: determinism): a small image
    by the gathered form (:data:`GATHER_BELOW`), the same bits."""
    if image.shape[dim] >= 3 and image.numel() < GATHER_BELOW:
        return _down_gathered(image, dim)
    return _down_forward(image, dim)


def _up(grad: torch.Tensor, n: int, dim: int) -> torch.Tensor:
    """The adjoint of :func:`_down` along ``dim`` of a level of ``n`` samples (a small
    gradient by the gathered form, :data:`UP_GATHER_BELOW`), the same bits."""
    if n >= 3 and grad.numel() < UP_GATHER_BELOW:
        return _up_gathered(grad, n, dim)
    return _down_backward(grad.contiguous(), n, dim)


def _levels(image: torch.Tensor, levels: int) -> list[torch.Tensor]:
    """[I_0, …, I_{levels−1}] of an image (H, W), rows down first (contiguous slices),
    without a graph."""
    out = [image]
    for _ in range(levels - 1):
        out.append(_down(_down(out[-1], -2), -1))
    return out


class _MultiscaleMSE(torch.autograd.Function):
    """Σ_s MSE(image_s, target_s) as one graph node: the levels computed without a graph,
    and the gradient walked back from the coarsest level, each level's
    ``mse_loss_backward`` added to the adjoint of the level below it (:func:`_up`,
    columns then rows). Autograd on a node per pyramid step and per level took the same
    steps: the same bits, with one node's bookkeeping instead of some thirty."""

    @staticmethod
    def forward(ctx: Any, image: torch.Tensor, levels: int,
                *targets: torch.Tensor) -> torch.Tensor:
        xs = _levels(image, levels)
        total = image.new_zeros(())
        for x, y in zip(xs, targets, strict=True):
            total = total + F.mse_loss(x, y.to(x.dtype))
        ctx.save_for_backward(*xs, *targets)
        ctx.levels = levels
        return total

    @staticmethod
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        saved = ctx.saved_tensors
        xs, ys = saved[:ctx.levels], saved[ctx.levels:]
        mean = 1  # torch's Reduction::Mean
        below: torch.Tensor | None = None  # the gradient arriving from the next level
        for x, y in zip(reversed(xs), reversed(ys), strict=True):
            own = torch.ops.aten.mse_loss_backward(grad, x, y.to(x.dtype), mean)
            if below is not None:  # columns were taken down last: they come back first
                own = own + _up(_up(below, x.shape[-1], -1), x.shape[-2], -2)
            below = own
        return (below, None, *(None for _ in ys))


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
    with torch.no_grad():
        target_levels = _levels(target, levels)

    def loss(rendered: torch.Tensor) -> torch.Tensor:
        assert rendered.shape[-2:] == (h, w), (rendered.shape, target.shape)
        return _MultiscaleMSE.apply(rendered.reshape(h, w), levels, *target_levels)

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
