"""Job kind "tag": a graffiti tag from a word (the paper's "CLIP-driven graffiti tag
generation", ClipDraw-style). A plain start trajectory (initialiser 'line', Δt = 1) is
optimised so that its rendering matches the caption "{word}, a stylish graffiti tag" in
CLIP's embedding space (image loss 'clip-text', paper eq. clip) while the smoothing cost
keeps it a rapid, human-like ΣΛ motion.

Artifacts: plan.json, drawing.svg, drawing.png, overlay.png (start in grey, result in
colour), speed.png, trajectory.csv, init.json and init.png (the start plan), plus job.json,
report.json and recording.rrd from the shell. The implementation is in
:mod:`inkmotion.kinds.generation`; importing this module imports no torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from inkmotion.jobs.kind import InputSpec
from inkmotion.kinds.generation import TagParams
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import JobKind

class TagKind:
    """The 'tag' job kind (see the module docstring)."""

    name = "tag"
    description = "Generate a graffiti tag from a word: CLIP text guidance on a ΣΛ motion."
    queue = "optimise"
    inputs = (InputSpec("word", "The word the tag should read as.", form="text"),)
    Params = TagParams
    examples = (
        "inkmotion run tag CREAM --out results/cream",
        "inkmotion run tag CREAM --out results/cream --targets 40 --steps 500",
        'inkmotion run tag KATO --caption "{word}, graffiti in a bold wild style" --out r/kato',
        "inkmotion run tag CREAM --varying-width --out results/cream-brush",
        "inkmotion run tag TEST --clip-weights random --steps 20 --out /tmp/t  # tests only",
    )

    def steps(self, params: TagParams) -> int:
        return params.steps

    def run(self, job: Job) -> dict[str, Any]:
        from inkmotion.kinds.generation import run_tag

        return run_tag(job)


@hookimpl
def inkmotion_job_kinds() -> list[JobKind]:
    return [TagKind()]
