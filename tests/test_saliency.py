"""Saliency plugins: maps in [0, 1] of the image's size, device and dtype; the disc test; the
clear refusals (no cv2.saliency, no transformers or no OneFormer weights)."""

from __future__ import annotations

import importlib.machinery
import sys
import types
import warnings
from pathlib import Path
from typing import Any

import pytest
import torch

import inkmotion
from inkmotion.errors import PluginError, SpecError
from inkmotion.plugin_host.protocols import Reference
from inkmotion.saliency.maps import gaussian_blur, normalise
from inkmotion.saliency.oneformer import thing_probability

TINY_CLIP = Path(__file__).parent / "data/clip/tiny-vit.json"


def _disc(h: int = 64, w: int = 80, cx: float = 48, cy: float = 30, r: float = 10) -> torch.Tensor:
    """A bright disc on a dark, faintly textured background, (3, H, W) in [0, 1]."""
    yy, xx = torch.meshgrid(torch.arange(h) + 0.5, torch.arange(w) + 0.5, indexing="ij")
    g = torch.Generator().manual_seed(0)
    img = 0.1 + 0.02 * torch.rand(3, h, w, generator=g)
    img[:, (xx - cx) ** 2 + (yy - cy) ** 2 <= r * r] = 0.9
    return img


def _check_map(m: torch.Tensor, image: torch.Tensor) -> None:
    assert m.shape == image.shape[-2:]
    assert m.device == image.device and m.dtype == image.dtype
    assert torch.isfinite(m).all() and m.min() >= 0 and m.max() <= 1
    assert m.max() == 1  # normalised (the inputs here are not constant)


@pytest.mark.parametrize("method", ["fine-grained", "spectral-residual"])
def test_spectral_disc_is_salient(method: str, device: torch.device) -> None:
    image = _disc().to(device)
    m = inkmotion.plugin("saliency", "spectral")(image, Reference(), method=method)
    _check_map(m, image)
    disc = m[20:41, 38:59].mean()  # the disc and its rim (centre 48, 30; radius 10)
    corner = m[:12, :12].mean()  # far from it
    assert disc > 3 * corner, (float(disc), float(corner))


@pytest.mark.parametrize("shape", [(64, 80), (1, 37, 53), (3, 7, 13), (3, 2, 2)])
def test_spectral_grey_and_odd_sizes(shape: tuple[int, ...]) -> None:
    image = torch.rand(shape, generator=torch.Generator().manual_seed(1), dtype=torch.float64)
    m = inkmotion.plugin("saliency", "spectral")(image, Reference())
    assert m.shape == shape[-2:] and m.dtype == torch.float64
    assert m.min() >= 0 and m.max() <= 1


def test_spectral_constant_image_is_zero() -> None:
    m = inkmotion.plugin("saliency", "spectral")(torch.full((3, 20, 30), 0.5), Reference())
    assert m.shape == (20, 30) and float(m.abs().max()) == 0.0


def test_spectral_without_contrib_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    import cv2

    monkeypatch.delattr(cv2, "saliency")
    with pytest.raises(PluginError, match="opencv-contrib-python-headless"):
        inkmotion.plugin("saliency", "spectral")(_disc(), Reference())


def test_blur_and_normalise() -> None:
    x = torch.zeros(21, 21)
    x[10, 10] = 1.0
    y = gaussian_blur(x, 2.0)
    assert abs(float(y.sum()) - 1.0) < 1e-5 and y[10, 10] == y.max()
    torch.testing.assert_close(y, y.T)
    assert float(normalise(torch.full((3, 3), 7.0)).abs().max()) == 0.0
    torch.testing.assert_close(normalise(torch.tensor([[2.0, 4.0, 3.0]])),
                               torch.tensor([[0.0, 1.0, 0.5]]))


def _tiny_clip() -> Any:
    """The tiny random-weight CLIP of the CLIP tests (a LoadedClip), or skip."""
    if not TINY_CLIP.is_file():
        pytest.skip(f"{TINY_CLIP} is missing (the CLIP module's test model config)")
    model = pytest.importorskip("inkmotion.clip.model", reason="inkmotion.clip.model missing")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "CLIP weights are random"
        return model.load_clip(str(TINY_CLIP), weights="random")


@pytest.mark.parametrize("caption", [None, "a white disc"])
def test_clip_relevancy_map(caption: str | None) -> None:
    clip = _tiny_clip()
    image = _disc(40, 56, 30, 20, 8)
    saliency = inkmotion.plugin("saliency", "clip")
    ref = Reference(image=image, caption=caption, extra={"clip": clip})
    m = saliency(image, ref, samples=4)
    _check_map(m, image)
    torch.testing.assert_close(m, saliency(image, ref, samples=4))  # seeded augmentations
    assert not torch.equal(m, saliency(image, ref, samples=4, seed=1))
    grey = saliency(image[0].double(), ref, samples=2)  # (H, W) grey, float64
    assert grey.shape == (40, 56) and grey.dtype == torch.float64


def test_clip_saliency_loads_its_model_from_options() -> None:
    _tiny_clip()
    image = torch.rand(3, 24, 33, generator=torch.Generator().manual_seed(2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "CLIP weights are random"
        m = inkmotion.plugin("saliency", "clip")(image, Reference(), model=str(TINY_CLIP),
                                                 weights="random", samples=2)
    _check_map(m, image)


def test_oneformer_refuses_without_transformers(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.util

    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "transformers"
                        else real_find_spec(name, *a))
    with pytest.raises(SpecError, match=r"install transformers .*--saliency spectral"):
        inkmotion.plugin("saliency", "oneformer")(_disc(), Reference())


def test_oneformer_refuses_without_local_weights(monkeypatch: pytest.MonkeyPatch) -> None:
    """transformers present, weights absent: from_pretrained(local_files_only=True) fails."""

    class _NotDownloaded:
        @classmethod
        def from_pretrained(cls, model_id: str, local_files_only: bool = False) -> None:
            assert local_files_only
            raise OSError(f"{model_id} is not in the cache")

    fake = types.ModuleType("transformers")
    fake.__spec__ = importlib.machinery.ModuleSpec("transformers", None)
    fake.OneFormerProcessor = fake.OneFormerForUniversalSegmentation = _NotDownloaded
    monkeypatch.setitem(sys.modules, "transformers", fake)
    with pytest.raises(SpecError, match=r"huggingface-cli download shi-labs/oneformer_coco"):
        inkmotion.plugin("saliency", "oneformer")(_disc(), Reference())


def test_thing_probability_is_maskformer_inference() -> None:
    # two queries: a confident "thing" (class 0) covering the left column, and a "stuff"
    # query (class 2) covering the right column; class 3 is "no object"
    class_logits = torch.log(torch.tensor([[0.9, 0.05, 0.03, 0.02], [0.0, 0.0, 1.0, 0.0]])
                             .clamp_min(1e-12))
    mask_logits = torch.tensor([[[20.0, -20.0]], [[-20.0, 20.0]]])  # (Q=2, h=1, w=2)
    s = thing_probability(class_logits, mask_logits, things=[0, 1])
    torch.testing.assert_close(s, torch.tensor([[0.95, 0.0]]), atol=1e-6, rtol=0)
