"""CLIP relevancy saliency: where the pixels are that CLIP's similarity depends on.

With a caption c (text embedding t = f_T(c)), the relevancy of pixel p is the magnitude of
the gradient of the image–caption cosine similarity (Simonyan et al. 2014's gradient
saliency, applied to CLIP as in CLIPasso's relevancy initialisation):

    R(p) = E_a [ Σ_ch | ∂ cos(f_I(a(x)), t) / ∂ x(p, ch) | ]

averaged over ``samples`` random augmentations a (a square window of 80–100 % of the
longer side at a random position, randomly mirrored, resampled to CLIP's input size with a
differentiable ``grid_sample``, so the gradient lands on the original pixel grid).
Averaging over views removes most of the ViT patch-grid and single-view noise.

With no caption the only target is the image itself, t = f_I(x). The plain gradient of
cos(f_I(x), f_I(x)) vanishes there (the similarity is at its maximum, 1), so the map is
integrated gradients (Sundararajan et al. 2017) from a blurred baseline x' (σ = 5 % of the
longer side, Sturmfels et al. 2020): with x_α = x' + α (x − x') and α ~ U(0, 1] per view,

    R(p) = E_{a, α} [ Σ_ch | (x − x')(p, ch) · ∂ cos(f_I(a(x_α)), t) / ∂ x_α(p, ch) | ]

which credits the image detail (what the blur removes) that CLIP's embedding of the image
depends on. Both maps are then blurred and normalised to [0, 1]
(:func:`inkmotion.saliency.maps.smooth_and_normalise`). Augmentations are drawn from a
generator seeded with ``seed``, so the map is deterministic on a device.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F

from inkmotion.saliency.maps import as_rgb, gaussian_blur, smooth_and_normalise

DEFAULT_SAMPLES = 8
#: blur σ (fraction of the longer side): coarser than the spectral map, CLIP sees 32-px patches
DEFAULT_BLUR = 0.02
#: σ of the integrated-gradients baseline blur, fraction of the longer side
BASELINE_BLUR = 0.05
MIN_SCALE = 0.8


def random_views(x: torch.Tensor, size: int, generator: torch.Generator) -> torch.Tensor:
    """Square views (B, 3, size, size) of images x (B, 3, H, W), one random window each.

    Window side L = s · max(H, W), s ~ U(0.8, 1), centre uniform where the window fits (or
    the image centre when it does not: the border is then repeated), mirrored with
    probability ½; resampled bilinearly with ``affine_grid``/``grid_sample`` (differentiable
    in x).
    """
    b, _, h, w = x.shape
    side = max(h, w)
    u = torch.rand(b, 4, generator=generator, dtype=torch.float64)  # on the CPU
    length = side * (MIN_SCALE + (1 - MIN_SCALE) * u[:, 0])  # (B,) px
    cx = torch.where(length < w, length / 2 + u[:, 1] * (w - length).clamp(min=0), w / 2)
    cy = torch.where(length < h, length / 2 + u[:, 2] * (h - length).clamp(min=0), h / 2)
    flip = torch.where(u[:, 3] < 0.5, -1.0, 1.0)
    theta = torch.zeros(b, 2, 3, dtype=torch.float64)
    theta[:, 0, 0] = flip * length / w
    theta[:, 0, 2] = 2 * cx / w - 1
    theta[:, 1, 1] = length / h
    theta[:, 1, 2] = 2 * cy / h - 1
    theta = theta.to(device=x.device, dtype=x.dtype)
    grid = F.affine_grid(theta, [b, 3, size, size], align_corners=False)
    return F.grid_sample(x, grid, mode="bilinear", padding_mode="border", align_corners=False)


def full_view(x: torch.Tensor, size: int) -> torch.Tensor:
    """The whole image x (B, 3, H, W) padded (border repeated) to a square and resized to
    (B, 3, size, size)."""
    b, _, h, w = x.shape
    side = max(h, w)
    theta = torch.tensor([[side / w, 0, 0], [0, side / h, 0]], dtype=x.dtype, device=x.device)
    grid = F.affine_grid(theta.expand(b, 2, 3), [b, 3, size, size], align_corners=False)
    return F.grid_sample(x, grid, mode="bilinear", padding_mode="border", align_corners=False)


def clip_relevancy(image: torch.Tensor, clip: Any, caption: str | None = None, *,
                   samples: int = DEFAULT_SAMPLES, blur: float = DEFAULT_BLUR,
                   seed: int = 0) -> torch.Tensor:
    """Relevancy map (H, W) in [0, 1] of ``image`` (3, H, W) or (H, W) in [0, 1].

    ``clip`` is a loaded CLIP model (:class:`inkmotion.clip.model.LoadedClip`: ``encode_image``
    of (B, 3, s, s) in [0, 1], ``encode_text``, ``image_size``, ``device``). With a
    ``caption`` the map is the mean |gradient| of the image–caption cosine similarity; with
    none, integrated gradients of the similarity to the image's own embedding (module
    docstring). The result is on the image's device and dtype.
    """
    rgb = as_rgb(image)
    out_dtype = image.dtype if image.is_floating_point() else torch.float32
    size = int(clip.image_size)
    x = rgb.detach().to(device=clip.device, dtype=torch.float32).clamp(0, 1)  # (3, H, W)
    generator = torch.Generator().manual_seed(int(seed))
    n = max(1, int(samples))
    with torch.no_grad():
        if caption:
            target = clip.encode_text([caption])
            baseline, alpha = None, torch.ones(n, 1, 1, 1)
        else:
            target = clip.encode_image(full_view(x[None], size))
            baseline = torch.stack([gaussian_blur(c, BASELINE_BLUR * max(x.shape[1:]))
                                    for c in x])  # (3, H, W)
            alpha = 1.0 - torch.rand(n, 1, 1, 1, generator=generator, dtype=torch.float64)
        target = F.normalize(target.float(), dim=-1)  # (1, E)
    alpha = alpha.to(device=x.device, dtype=x.dtype)
    start = x if baseline is None else baseline
    path = (start + alpha * (x - start)).detach().requires_grad_(True)  # (B, 3, H, W)
    with torch.enable_grad():
        emb = F.normalize(clip.encode_image(random_views(path, size, generator)).float(), dim=-1)
        similarity = (emb * target).sum()  # Σ_b cos(f(a_b(x_b)), t): each view's own gradient
        (grad,) = torch.autograd.grad(similarity, path)
    if baseline is not None:
        grad = grad * (x - baseline)
    raw = grad.abs().sum(dim=1).mean(dim=0)  # (H, W)
    return smooth_and_normalise(raw.to(device=image.device, dtype=out_dtype), blur)
