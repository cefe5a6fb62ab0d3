"""CLIP generation benchmarks: seconds per optimisation step of a 'tag' (ViT-B-32, 4
augmentations, 224 px) and of an 'abstract' (150 targets of a voronoi-tsp tour, clip-visual).

They run the real job kinds on randomly initialised ViT-B-32 weights (same architecture and
cost as the pretrained ones; nothing is downloaded), so the figures are speeds only, never
quality. ``tag_300_steps_s`` extrapolates a 300-step tag from the measured steps.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from inkmotion.jobs.spec import JobSpec


def _photo(folder: Path) -> str:
    """scikit-image's astronaut when installed (the issue's sample), else a synthetic photo."""
    import cv2
    import numpy as np

    try:
        from skimage import data

        rgb = data.astronaut()
    except ImportError:  # a gradient with a disc: enough to time the job
        yy, xx = np.mgrid[0:512, 0:512]
        rgb = np.stack([xx / 2, yy / 2, 128 + 0 * xx], -1).astype(np.uint8)
        rgb[(xx - 256) ** 2 + (yy - 200) ** 2 < 90**2] = (230, 200, 90)
    path = folder / "photo.png"
    cv2.imwrite(str(path), rgb[:, :, ::-1])
    return str(path)


def _s_per_step(spec: JobSpec, folder: Path) -> tuple[float, dict]:
    import warnings

    from inkmotion.jobs.shell import run_job

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the random-weights warning: known here
        report = run_job(spec, folder / spec.kind)
    return report["fit_s"] / report["steps"], report


def bench_generation(steps: int = 10, device: str = "cpu") -> dict[str, float | int]:
    """Seconds per step of a tag and of an abstraction at the defaults (``steps`` each)."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        common = {"steps": steps, "clip_weights": "random"}
        tag = JobSpec(kind="tag", inputs={"word": "CREAM"}, device=device, params=common)
        tag_s, tag_report = _s_per_step(tag, folder)
        abstract = JobSpec(kind="abstract", inputs={"image": _photo(folder)}, device=device,
                           params=common)
        abstract_s, abstract_report = _s_per_step(abstract, folder)
    return {
        "tag_s_per_step": tag_s,
        # the 30-s goal is for a CUDA GPU: the CPU figure carries no target
        ("tag_300_steps_s" if device != "cpu" else "tag_300_steps_cpu_s"): 300 * tag_s,
        "tag_moves": tag_report["moves"],
        "abstract_s_per_step": abstract_s,
        "abstract_moves": abstract_report["moves"],
    }
