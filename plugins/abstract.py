"""Job kind "abstract": a photo drawn as ONE continuous stroke (the paper's "CLIP-driven
image abstraction", CLIPasso-style). A saliency map of the photo places the virtual targets
(initialiser 'voronoi-tsp': weighted Voronoi stippling joined by a TSP tour), and the one
path is optimised so that CLIP's intermediate activations of its rendering match the
photo's (image loss 'clip-visual', paper eq. clip2), optionally with a varying width.

Artifacts: plan.json, drawing.svg, drawing.png, overlay.png (the drawing over the faded
photo), speed.png, trajectory.csv, init.json, init.png (the start tour over the photo) and
saliency.png, plus job.json, report.json and recording.rrd from the shell. The
implementation is in :mod:`inkmotion.kinds.generation`; importing this module imports no torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from inkmotion.jobs.kind import InputSpec
from inkmotion.kinds.generation import AbstractParams
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.kind import ResolvedJob
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import JobKind


class AbstractKind:
    """The 'abstract' job kind (see the module docstring)."""

    name = "abstract"
    description = "Draw a photo as one continuous ΣΛ stroke: saliency, TSP tour, CLIPasso loss."
    queue = "optimise"
    inputs = (InputSpec("image", "A photo (PNG or JPEG, any size, grey, colour or with "
                                 "alpha) or sample:NAME.",
                        form="file"),)
    Params = AbstractParams
    examples = (
        "inkmotion run abstract my_photo.jpg --out results/photo",
        "inkmotion run abstract sample:shapes --targets 300 --varying-width --out results/brush",
        "inkmotion run abstract dog.png --saliency clip --caption 'a dog' --out results/dog",
        "inkmotion run abstract sample:shapes --clip-weights random --steps 10 --out results/t"
        "  # tests",
    )

    def steps(self, params: AbstractParams) -> int:
        return params.steps

    def check_inputs(self, job: ResolvedJob) -> None:
        """Refuse a photo the run could not read (``inkmotion submit`` asks first)."""
        from inkmotion.kinds.read import check_photo_input

        check_photo_input(job)

    def run(self, job: Job) -> dict[str, Any]:
        from inkmotion.kinds.generation import run_abstract

        return run_abstract(job)


@hookimpl
def inkmotion_job_kinds() -> list[JobKind]:
    return [AbstractKind()]
