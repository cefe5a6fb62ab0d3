"""The paper's saliency: OneFormer panoptic segmentation (Jain et al. 2023) trained on COCO.

The paper derives its saliency map "from the last-layer activations of the OneFormer
panoptic image segmentation model". OneFormer (like MaskFormer, Cheng et al. 2021) ends in
Q queries, each with class probabilities p_q(c) (softmax over the 133 COCO-panoptic classes
and "no object") and a mask m_q(p) = sigmoid(mask logit) at every pixel. MaskFormer's
semantic inference turns these into per-pixel class scores

    s(p, c) = Σ_q p_q(c) · m_q(p),

and the saliency is the score of the *things* (countable objects: people, animals,
vehicles, ...; not "stuff" such as sky, wall or grass):

    S(p) = Σ_{c ∈ things} s(p, c),

bilinearly resized to the image, blurred and normalised to [0, 1]. The thing classes are
the processor's ``metadata["thing_ids"]`` when it has them, else COCO-panoptic's first 80
labels (the 80 COCO object classes precede the 53 stuff classes).

Runs only where the optional ``transformers`` package is installed and the model's
weights are on disk (``from_pretrained(..., local_files_only=True)``: nothing is
downloaded); otherwise a :class:`~inkmotion.errors.SpecError` says what to install.
"""

from __future__ import annotations

import importlib.util
from typing import Any

import torch
import torch.nn.functional as F

from inkmotion.errors import SpecError
from inkmotion.saliency.maps import DEFAULT_BLUR, as_rgb, smooth_and_normalise

DEFAULT_MODEL_ID = "shi-labs/oneformer_coco_swin_large"
#: COCO panoptic: labels 0..79 are things, 80..132 stuff
COCO_THINGS = 80


def load_oneformer(model_id: str = DEFAULT_MODEL_ID,
                   device: torch.device | str | None = None) -> tuple[Any, Any]:
    """(processor, model) of ``model_id`` from local files only, model in eval mode.

    Raises a one-sentence :class:`SpecError` when ``transformers`` is missing or the
    weights are not on disk.
    """
    if importlib.util.find_spec("transformers") is None:
        raise SpecError("The oneformer saliency needs the optional `transformers` package "
                        f"and the {model_id} weights; install transformers or use "
                        "--saliency spectral.")
    try:
        from transformers import OneFormerForUniversalSegmentation, OneFormerProcessor

        processor = OneFormerProcessor.from_pretrained(model_id, local_files_only=True)
        model = OneFormerForUniversalSegmentation.from_pretrained(model_id,
                                                                  local_files_only=True)
    except (OSError, ValueError, ImportError) as err:
        raise SpecError(f"The oneformer saliency found no local weights for {model_id}; "
                        f"download them once with `huggingface-cli download {model_id}` or "
                        "use --saliency spectral.") from err
    return processor, model.to(device).eval()


def thing_ids(processor: Any, num_classes: int) -> list[int]:
    """The class indices that are things (see the module docstring)."""
    metadata = getattr(getattr(processor, "image_processor", processor), "metadata", None)
    ids = metadata.get("thing_ids") if isinstance(metadata, dict) else None
    if ids:
        return [int(i) for i in ids if 0 <= int(i) < num_classes]
    return list(range(min(COCO_THINGS, num_classes)))


def thing_probability(class_logits: torch.Tensor, mask_logits: torch.Tensor,
                      things: list[int]) -> torch.Tensor:
    """S = Σ_{c ∈ things} Σ_q softmax(class_logits)_q(c) · sigmoid(mask_logits)_q.

    ``class_logits`` (Q, C + 1) (last: no object), ``mask_logits`` (Q, h, w) -> (h, w).
    """
    probs = class_logits.softmax(dim=-1)[:, :-1]  # (Q, C)
    thing_mass = probs[:, things].sum(dim=-1)  # (Q,)
    return torch.einsum("q,qhw->hw", thing_mass, mask_logits.sigmoid())


def oneformer_saliency(image: torch.Tensor, model_id: str = DEFAULT_MODEL_ID,
                       blur: float = DEFAULT_BLUR) -> torch.Tensor:
    """OneFormer thing-probability saliency (H, W) in [0, 1] of ``image`` (3, H, W) in [0, 1],
    on the image's device and dtype."""
    rgb = as_rgb(image)
    h, w = rgb.shape[1:]
    processor, model = load_oneformer(model_id, image.device)
    u8 = (rgb.detach().float().clamp(0, 1) * 255).round().to(torch.uint8)
    inputs = processor(images=u8.permute(1, 2, 0).cpu().numpy(), task_inputs=["panoptic"],
                       return_tensors="pt")
    inputs = {k: v.to(image.device) if torch.is_tensor(v) else v for k, v in inputs.items()}
    with torch.no_grad():
        out = model(**inputs)
    class_logits = out.class_queries_logits[0].float()  # (Q, C + 1)
    mask_logits = out.masks_queries_logits[0].float()  # (Q, h', w')
    raw = thing_probability(class_logits, mask_logits,
                            thing_ids(processor, class_logits.shape[-1] - 1))
    raw = F.interpolate(raw[None, None], size=(h, w), mode="bilinear", align_corners=False)[0, 0]
    dtype = image.dtype if image.is_floating_point() else torch.float32
    return smooth_and_normalise(raw.to(dtype), blur)
