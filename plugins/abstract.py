"""Job kind "abstract": a photo drawn as ONE continuous stroke (the paper's "CLIP-driven
image abstraction", CLIPasso-style). A saliency map of the photo places the virtual targets
(initialiser 'voronoi-tsp': weighted Voronoi stippling joined by a TSP tour), and the one
path is optimised so that CLIP's intermediate activations of its rendering match the
photo's (image loss 'clip-visual', paper eq. clip2), optionally with a varying width.

Artifacts: plan.json, drawing.svg, drawing.png, overlay.png (the drawing over the faded
photo), speed.png, trajectory.csv, init.json, init.png (the start tour over the photo) and
saliency.png, plus job.json, report.json and recording.rrd from the shell. The
implementation is in :mod:`inkmotion.generation.run`; importing this module imports no torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.generation.params import GenerationParams
from inkmotion.jobs.kind import InputSpec
from inkmotion.jobs.params import PluginChoice, param, plugin_param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.shell import Job


@dataclass
class AbstractParams(GenerationParams):
    """Parameters of an abstraction (the shared ones are :class:`GenerationParams`)."""

    targets: int = param(150, "Number of virtual targets of the tour (the paper's 150).",
                         minimum=2, maximum=5000)
    width: float = param(2.0, "Stroke width, px (the start width with --varying-width).",
                         minimum=0.1, maximum=256)
    caption: str = param("", "Optional caption, used by caption-aware saliency (clip).")
    saliency: PluginChoice = plugin_param("saliency", "spectral",
                                          "Saliency plugin that places the targets.")
    initialiser: PluginChoice = plugin_param("initialiser", "voronoi-tsp",
                                             "Initialiser plugin.")
    losses: list[PluginChoice] = plugin_param("image-loss", "clip-visual",
                                              "Image-loss plugin (repeatable).", many=True,
                                              flag="--loss")

    def validate(self) -> None:
        super().validate()
        if not self.losses:
            raise SpecError("The abstract job needs at least one image loss "
                            "(e.g. --loss clip-visual).")


class AbstractKind:
    """The 'abstract' job kind (see the module docstring)."""

    name = "abstract"
    description = "Draw a photo as one continuous ΣΛ stroke: saliency, TSP tour, CLIPasso loss."
    queue = "optimise"
    inputs = (InputSpec("image", "A photo: PNG or JPEG, any size, grey, colour or with alpha.",
                        form="file"),)
    Params = AbstractParams
    examples = (
        "inkmotion run abstract photo.jpg --out results/photo",
        "inkmotion run abstract photo.jpg --targets 300 --varying-width --out results/brush",
        "inkmotion run abstract photo.png --saliency clip --caption 'a dog' --out results/dog",
        "inkmotion run abstract photo.png --clip-weights random --steps 10 --out /tmp/a  # tests",
    )

    def steps(self, params: AbstractParams) -> int:
        return params.steps

    def run(self, job: Job) -> dict[str, Any]:
        from inkmotion.generation.run import run_abstract

        return run_abstract(job)


@hookimpl
def inkmotion_job_kinds() -> list:
    return [AbstractKind()]
