"""A CLIP model (open_clip) loaded once per process, with honestly recorded weights.

:func:`load_clip` builds the model named by (model, pretrained, weights) — see
:mod:`inkmotion.clip.weights` for what the three strings mean — and never downloads:
``"auto"`` takes the tag's file from open_clip's cache only, and :func:`weights_problem`
says in one sentence, before any work, what is missing and how to get it. The one function
that uses the network is :func:`download_weights` (for a command line run once).

:class:`LoadedClip` wraps the model with the three operations the losses and the saliency
need: image embeddings (differentiable), text embeddings (no gradient) and the intermediate
activations of the visual transformer (differentiable). Images are (B, 3, h, w) RGB in
[0, 1] of any size: they are resized (bilinear, antialiased) to the encoder's input size and
normalised with the weights' mean and std here, so callers never see CLIP's preprocessing.

Layer indexing (:meth:`LoadedClip.image_activations`): layer l is the output of
``model.visual.transformer.resblocks[l]``, i.e. after l + 1 residual blocks — CLIPasso's
index (its ``clip_conv_layer_weights[l]`` weighs ``featuremaps[l]``, the output of block
l counted from 0), which is how the paper's λ2 = λ3 = 0.5, λ6 = 1 are meant. Each
activation is (B, L, D): the class token and the patch tokens, batch first.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch
import torch.nn.functional as F

from inkmotion.clip.weights import (
    AUTO,
    DEFAULT_MODEL,
    DEFAULT_PRETRAINED,
    RANDOM,
    WeightsProblem,
    download,
    resolve,
)
from inkmotion.clip.weights import weights_problem as _weights_problem
from inkmotion.errors import InputError, SpecError

__all__ = ["AUTO", "DEFAULT_MODEL", "DEFAULT_PRETRAINED", "RANDOM", "LoadedClip",
           "clear_cache", "download_weights", "load_clip", "weights_problem"]

#: CLIP's (OpenAI's) normalisation, the fallback when neither the tag nor the config has one
OPENAI_MEAN = (0.48145466, 0.4578275, 0.40821073)
OPENAI_STD = (0.26862954, 0.26130258, 0.27577711)

RANDOM_WARNING = "CLIP weights are random: results are meaningless except for tests"


@dataclass
class LoadedClip:
    """An open_clip model in eval mode with frozen parameters, and where its weights came
    from (``weights``: "random", "open_clip:<tag>" or the checkpoint path, for job.json)."""

    model: Any
    name: str
    weights: str
    image_size: int  # the visual encoder's input side (224 for ViT-B-32)
    device: torch.device
    mean: tuple[float, ...] = OPENAI_MEAN
    std: tuple[float, ...] = OPENAI_STD
    _tokenizer: Any = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        self.device = torch.device(self.device)
        dtype = next(self.model.parameters()).dtype
        self._dtype = dtype
        self._mean = torch.tensor(self.mean, dtype=dtype).view(1, 3, 1, 1).to(self.device)
        self._std = torch.tensor(self.std, dtype=dtype).view(1, 3, 1, 1).to(self.device)

    @property
    def depth(self) -> int:
        """Number of residual blocks of the visual transformer (0 when it has none)."""
        blocks = getattr(getattr(self.model.visual, "transformer", None), "resblocks", None)
        return 0 if blocks is None else len(blocks)

    def preprocess(self, images: torch.Tensor) -> torch.Tensor:
        """(B, 3, h, w) RGB in [0, 1] -> (B, 3, S, S) resized (bilinear, antialiased) and
        normalised, (x − mean)/std, in the model's dtype on its device; differentiable."""
        assert images.ndim == 4 and images.shape[1] == 3, images.shape
        x = images.to(device=self.device, dtype=self._dtype)
        size = (self.image_size, self.image_size)
        if tuple(x.shape[-2:]) != size:
            x = F.interpolate(x, size=size, mode="bilinear", antialias=True,
                              align_corners=False)
        return (x - self._mean) / self._std

    def encode_image(self, images: torch.Tensor) -> torch.Tensor:
        """(B, E) L2-normalised image embeddings f(I) of (B, 3, h, w) RGB in [0, 1],
        differentiable with respect to ``images``."""
        return F.normalize(self.model.encode_image(self.preprocess(images)), dim=-1)

    def _text_tokenizer(self) -> Any:
        if self._tokenizer is None:
            import open_clip

            try:
                self._tokenizer = open_clip.get_tokenizer(self.name)
            except Exception as exc:  # e.g. a Hugging Face tokenizer that is not cached
                raise SpecError(f"The tokenizer of the CLIP model {self.name} could not be "
                                f"loaded ({_first_line(exc)}); use a model with open_clip's "
                                "own tokenizer, such as ViT-B-32.") from None
        return self._tokenizer

    def tokens_cut(self, text: str) -> tuple[int, int]:
        """(tokens of ``text`` with its start and end marks, the context length CLIP reads):
        the tokens past the context are cut off, unseen (0, 0 for a tokenizer that cannot
        count them)."""
        tokenizer = self._text_tokenizer()
        encode = getattr(tokenizer, "encode", None)
        context = getattr(tokenizer, "context_length", None)
        if encode is None or not isinstance(context, int):
            return 0, 0
        return len(encode(text)) + 2, context

    def encode_text(self, texts: list[str]) -> torch.Tensor:
        """(B, E) L2-normalised text embeddings f(c), without gradient."""
        tokens = self._text_tokenizer()(list(texts)).to(self.device)
        with torch.no_grad():
            return F.normalize(self.model.encode_text(tokens), dim=-1)

    def image_activations(self, images: torch.Tensor, layers: Sequence[int]
                          ) -> dict[int, torch.Tensor]:
        """{l: (B, L, D)} the outputs of visual residual blocks ``resblocks[l]`` (CLIPasso's
        index, from 0; see the module docstring) for (B, 3, h, w) RGB in [0, 1];
        differentiable. Blocks after the deepest requested layer are not run."""
        depth = self.depth
        if depth == 0 or not hasattr(self.model.visual, "forward_intermediates"):
            raise SpecError(f"The CLIP model {self.name} has no vision transformer blocks "
                            "(model.visual.transformer.resblocks) to take layer activations "
                            "from; use a ViT model such as ViT-B-32.")
        wanted = sorted(set(int(layer) for layer in layers))
        bad = [layer for layer in wanted if not 0 <= layer < depth]
        if bad:
            raise SpecError(f"CLIP layer {bad[0]} does not exist in {self.name}, whose image "
                            f"encoder has layers 0..{depth - 1}; choose layers in that range.")
        out = self.model.visual.forward_intermediates(
            self.preprocess(images), indices=wanted, stop_early=True, intermediates_only=True,
            output_fmt="NLC", output_extra_tokens=True)
        prefix = out.get("image_intermediates_prefix")
        acts = out["image_intermediates"]
        if prefix is not None:  # class token first, as the blocks see it
            acts = [torch.cat((p, a), dim=1) for p, a in zip(prefix, acts, strict=True)]
        return dict(zip(wanted, acts, strict=True))


def weights_problem(model: str, pretrained: str, weights: str) -> str | None:
    """None when :func:`load_clip` would succeed without network; else one sentence saying
    what is missing and how to get it. Cheap: builds no model."""
    return _weights_problem(model, pretrained, weights)


#: models built in this process: (model, pretrained, weights, device) -> LoadedClip, so a
#: job that uses CLIP for its saliency and its loss builds it once
_LOADED: dict[tuple[str, str, str, str], LoadedClip] = {}


def clear_cache() -> None:
    """Forget the models built so far (tests; freeing memory)."""
    _LOADED.clear()


def load_clip(model: str = DEFAULT_MODEL, pretrained: str = DEFAULT_PRETRAINED,
              weights: str = AUTO, device: torch.device | str = "cpu") -> LoadedClip:
    """The CLIP model (model, pretrained, weights) on ``device``, built once per process.

    Never downloads. ``weights="random"`` initialises under a fixed seed (torch's global RNG
    is left as it was), so runs reproduce, and warns that the results are meaningless.
    Raises :class:`SpecError` (unknown model, weights not available offline) or
    :class:`InputError` (a checkpoint that does not load into the model), one sentence each.
    """
    device = torch.device(device)
    if device.type == "cuda" and device.index is None:  # "cuda" and "cuda:0" are one device
        device = torch.device("cuda", torch.cuda.current_device())
    key = (model, pretrained, weights, str(device))
    if key in _LOADED:
        return _LOADED[key]
    try:
        found = resolve(model, pretrained, weights)
    except WeightsProblem as exc:
        raise SpecError(str(exc)) from None
    net = _build(found.name, found.checkpoint, bool(found.tag_cfg.get("quick_gelu", False)))
    if found.checkpoint is None:  # said once, here (open_clip's own notice is held back)
        warnings.warn(RANDOM_WARNING, stacklevel=2)
    net = net.to(device).eval().requires_grad_(False)
    preprocess = getattr(net.visual, "preprocess_cfg", None) or {}
    mean = found.tag_cfg.get("mean") or preprocess.get("mean") or OPENAI_MEAN
    std = found.tag_cfg.get("std") or preprocess.get("std") or OPENAI_STD
    size = getattr(net.visual, "image_size", 224)
    size = size if isinstance(size, int) else size[0]
    loaded = LoadedClip(net, found.name, found.weights, int(size), device, tuple(mean),
                        tuple(std))
    _LOADED[key] = loaded
    return loaded


def _build(name: str, checkpoint: Path | None, quick_gelu: bool) -> Any:
    """open_clip.create_model on the CPU under a fixed seed; load errors as one sentence."""
    import open_clip

    with torch.random.fork_rng(devices=[]), _without_random_notice():
        torch.manual_seed(0)
        try:
            return open_clip.create_model(
                name, pretrained=None if checkpoint is None else str(checkpoint),
                force_quick_gelu=quick_gelu, pretrained_image=False, pretrained_text=False,
                device="cpu")
        except Exception as exc:  # any failure is the input's: said once, in a sentence
            reason = _first_line(exc)
            if checkpoint is not None:
                raise InputError(f"The CLIP weights file {checkpoint} does not load into the "
                                 f"model {name} ({reason}); pass a checkpoint of that model "
                                 "or the matching --clip-model.") from None
            raise SpecError(f"The CLIP model {name} could not be built ({reason}); check its "
                            "model config.") from None


#: how open_clip's notice of a randomly initialised model begins
_OPEN_CLIP_NOTICE = "No pretrained weights loaded"


class _LastResort(logging.Handler):
    """What logging does with a record when no handler is configured (its last resort)."""

    def emit(self, record: logging.LogRecord) -> None:
        last = logging.lastResort
        if last is not None and record.levelno >= last.level:
            last.handle(record)


@contextmanager
def _without_random_notice() -> Iterator[None]:
    """Hold back open_clip's "No pretrained weights loaded ..." line: it goes to the root
    logger (and configures it with a handler to stderr when it has none), while
    :func:`load_clip` warns of random weights itself, once. Other records pass."""
    root = logging.getLogger()
    placeholder = None
    if not root.handlers:  # so logging.warning() does not install a stderr handler
        placeholder = _LastResort()
        root.addHandler(placeholder)

    def keep(record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith(_OPEN_CLIP_NOTICE)

    root.addFilter(keep)
    try:
        yield
    finally:
        root.removeFilter(keep)
        if placeholder is not None:
            root.removeHandler(placeholder)


def _first_line(exc: Exception) -> str:
    """An exception's first line (at most 200 characters), or its type's name; a missing
    key is said as one (a bare KeyError reads as just the key: "(105)")."""
    if isinstance(exc, KeyError) and exc.args:
        return f"it has no entry {exc.args[0]!r} the model reads"
    text = str(exc).strip()
    return text.splitlines()[0][:200] if text else type(exc).__name__


def download_weights(model: str, pretrained: str) -> Path:
    """Fetch the weights of (model, pretrained) into open_clip's cache, where
    ``weights="auto"`` finds them; the only function here that uses the network."""
    return download(model, pretrained)
