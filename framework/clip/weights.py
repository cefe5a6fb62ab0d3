"""Where a CLIP model's weights come from, decided without building the model or touching
the network.

A job names its CLIP model with three strings:

- ``model``: an open_clip model name (``ViT-B-32``) or the path of an open_clip
  model-config JSON file (registered with ``open_clip.add_model_config``; its stem is the
  model's name).
- ``pretrained``: an open_clip pretrained tag (``laion2b_s34b_b79k``), used by ``"auto"``.
- ``weights``: ``"auto"`` (the tag's file from open_clip's own cache, never downloaded
  here), a local checkpoint file (open_clip or OpenAI format), or ``"random"`` (a random
  initialisation: only meaningful for tests).

:func:`resolve` turns them into a :class:`Resolved` (the model's name and the checkpoint
file, or None for random weights) or one sentence saying what is missing and how to get
it. :func:`download` is the one function here that uses the network: it fills open_clip's
cache for ``"auto"`` (Hugging Face hub cache, or ``~/.cache/clip`` for URL weights).

This module imports neither torch nor open_clip at import time (the plugin modules read its
defaults); open_clip is imported inside the functions.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

DEFAULT_MODEL = "ViT-B-32"
DEFAULT_PRETRAINED = "laion2b_s34b_b79k"  # open_clip's LAION-2B tag for ViT-B-32

RANDOM = "random"
AUTO = "auto"

#: open_clip's file names on the Hugging Face hub (open_clip.constants)
HF_WEIGHTS_NAME = "open_clip_pytorch_model.bin"
HF_SAFE_WEIGHTS_NAME = "open_clip_model.safetensors"


@dataclass(frozen=True)
class Resolved:
    """What :func:`resolve` found: the model's open_clip name, the checkpoint to load
    (None: random weights), how job.json records the weights, and the tag's settings."""

    name: str
    checkpoint: Path | None
    weights: str  # "random", "open_clip:<tag>" or the checkpoint path
    tag_cfg: dict[str, Any]  # open_clip's pretrained config of the tag ({} unless "auto")


class WeightsProblem(Exception):
    """Internal: carries the one sentence of :func:`weights_problem`."""


def download_hint(model: str, pretrained: str) -> str:
    """The ways out of missing weights, as the end of a sentence."""
    return (f"run `inkmotion clip download --model {model} --pretrained {pretrained}` once "
            "with network, or pass --clip-weights PATH (an open_clip checkpoint), or "
            "--clip-weights random for tests")


def hf_hub_cache() -> Path:
    """The Hugging Face hub cache folder, read from the environment now (HF_HUB_CACHE,
    HF_HOME/hub, XDG_CACHE_HOME/huggingface/hub, ~/.cache/huggingface/hub), so a changed
    environment is honoured even after huggingface_hub was imported."""
    hub = os.environ.get("HF_HUB_CACHE") or os.environ.get("HUGGINGFACE_HUB_CACHE")
    if hub:
        return Path(hub).expanduser()
    home = os.environ.get("HF_HOME")
    if not home:
        xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join("~", ".cache")
        home = os.path.join(xdg, "huggingface")
    return Path(home).expanduser() / "hub"


def url_cache() -> Path:
    """open_clip's folder for weights downloaded from a URL (``~/.cache/clip``)."""
    return Path(os.path.expanduser(os.path.join("~", ".cache", "clip")))


def model_name(model: str) -> str:
    """The open_clip name of ``model``, registering a model-config JSON file first.

    Raises :class:`WeightsProblem` for an unknown name or an unreadable config file.
    """
    import open_clip

    path = Path(model).expanduser()
    if model.endswith(".json") or path.is_file():
        if not path.is_file():
            raise WeightsProblem(f"The CLIP model config file {model} does not exist; pass an "
                                 "open_clip model name (e.g. ViT-B-32) or an existing "
                                 "model-config JSON file.")
        try:
            cfg = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise WeightsProblem(f"The CLIP model config file {model} is not readable JSON "
                                 f"({exc}); fix it or pass an open_clip model name.") from None
        if not (isinstance(cfg, dict) and "vision_cfg" in cfg and "text_cfg" in cfg):
            raise WeightsProblem(f"The CLIP model config file {model} lacks vision_cfg and "
                                 "text_cfg; pass an open_clip model-config JSON file.")
        if open_clip.get_model_config(path.stem) != cfg:
            open_clip.add_model_config(path)
        return path.stem
    name = model.replace("/", "-")  # open_clip's spelling of OpenAI's "ViT-B/32"
    if open_clip.get_model_config(name) is None:
        raise WeightsProblem(f"Unknown CLIP model {model!r}; pass one of open_clip's models "
                             "(e.g. ViT-B-32, see open_clip.list_models()) or a model-config "
                             "JSON file.")
    return name


def _hf_candidates(filename: str) -> list[str]:
    """The files open_clip tries on the hub for ``filename``: safetensors first."""
    filename = filename or HF_WEIGHTS_NAME
    out = []
    if filename == HF_WEIGHTS_NAME:
        out.append(HF_SAFE_WEIGHTS_NAME)
    elif filename.endswith((".bin", ".pth")):
        out.append(filename[:-4] + ".safetensors")
    return out + [filename]


def cached_checkpoint(tag_cfg: dict[str, Any]) -> Path | None:
    """The tag's checkpoint in open_clip's cache (the hub cache or ``~/.cache/clip``), or
    None when it is not there. Reads only the local disk."""
    if tag_cfg.get("file"):
        path = Path(tag_cfg["file"])
        return path if path.is_file() else None
    if tag_cfg.get("hf_hub"):
        from huggingface_hub import try_to_load_from_cache

        repo, filename = os.path.split(tag_cfg["hf_hub"])
        for name in _hf_candidates(filename):
            found = try_to_load_from_cache(repo, name, cache_dir=str(hf_hub_cache()))
            if isinstance(found, str) and os.path.isfile(found):
                return Path(found)
    if tag_cfg.get("url"):
        path = url_cache() / os.path.basename(tag_cfg["url"])
        if path.is_file():
            return path
    return None


def _tag_cfg(name: str, pretrained: str) -> dict[str, Any]:
    import open_clip

    cfg = open_clip.get_pretrained_cfg(name, pretrained)
    if not cfg:
        tags = open_clip.list_pretrained_tags_by_model(name)
        known = f"its tags are {', '.join(tags)}" if tags else "it has no pretrained tags"
        raise WeightsProblem(f"The CLIP model {name} has no pretrained tag {pretrained!r} "
                             f"({known}); pass a known --clip-pretrained tag, or "
                             "--clip-weights PATH (an open_clip checkpoint).")
    return dict(cfg)


def resolve(model: str, pretrained: str, weights: str) -> Resolved:
    """Where the weights of (model, pretrained, weights) are, without network or model.

    Raises :class:`WeightsProblem` with one sentence when they cannot be had offline.
    """
    name = model_name(model)
    if weights == RANDOM:
        return Resolved(name, None, RANDOM, {})
    if weights == AUTO:
        cfg = _tag_cfg(name, pretrained)
        path = cached_checkpoint(cfg)
        if path is None:
            raise WeightsProblem(
                f"The CLIP weights {name}/{pretrained} are not in the local cache "
                f"({hf_hub_cache()} or {url_cache()}); {download_hint(model, pretrained)}.")
        return Resolved(name, path, f"open_clip:{pretrained}", cfg)
    path = Path(weights).expanduser()
    if not path.is_file():
        raise WeightsProblem(f"The CLIP weights file {weights} does not exist; pass an "
                             "existing open_clip checkpoint file, 'auto' (open_clip's cache) "
                             "or 'random' (tests only).")
    if not os.access(path, os.R_OK):
        raise WeightsProblem(f"The CLIP weights file {weights} is not readable; fix its "
                             "permissions or pass another checkpoint.")
    return Resolved(name, path, str(path), {})


def weights_problem(model: str, pretrained: str, weights: str) -> str | None:
    """None when the weights can be loaded without network; else one sentence saying what
    is missing and how to get it. Builds no model."""
    try:
        resolve(model, pretrained, weights)
    except WeightsProblem as exc:
        return str(exc)
    return None


def download(model: str, pretrained: str) -> Path:
    """Download the weights of ``pretrained`` into open_clip's cache (the only function of
    :mod:`inkmotion.clip` that uses the network) and return the file's path.

    Weights on the Hugging Face hub go to :func:`hf_hub_cache`, URL weights to
    :func:`url_cache`: where ``weights="auto"`` looks for them afterwards.
    """
    from open_clip.pretrained import download_pretrained_from_hf, download_pretrained_from_url

    from inkmotion.errors import SpecError

    try:
        name = model_name(model)
        cfg = _tag_cfg(name, pretrained)
    except WeightsProblem as exc:
        raise SpecError(str(exc)) from None
    found = cached_checkpoint(cfg)
    if found is not None:
        return found
    from inkmotion.errors import ServiceError

    source = cfg.get("hf_hub") or cfg.get("url")
    try:
        if cfg.get("hf_hub"):
            repo, filename = os.path.split(cfg["hf_hub"])
            return Path(download_pretrained_from_hf(repo, filename=filename or None,
                                                    cache_dir=str(hf_hub_cache())))
        if cfg.get("url"):
            return Path(download_pretrained_from_url(cfg["url"],
                                                     cache_dir=str(url_cache())))
    except Exception as exc:  # noqa: BLE001 - the hub's and urllib's errors alike
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        reason = text.split(". ")[0][:120]
        raise ServiceError(f"The CLIP weights {name}/{pretrained} could not be downloaded "
                           f"from {source} ({reason}); connect this machine to the internet "
                           "and try again, or copy an open_clip checkpoint here and pass "
                           "--clip-weights PATH.") from exc
    raise SpecError(f"The CLIP weights {name}/{pretrained} name no download source; pass "
                    "--clip-weights PATH (an open_clip checkpoint).")
