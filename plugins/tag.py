"""Job kind "tag": a graffiti tag from a word (the paper's "CLIP-driven graffiti tag
generation", ClipDraw-style). A plain start trajectory (initialiser 'line', Δt = 1) is
optimised so that its rendering matches the caption "{word}, a stylish graffiti tag" in
CLIP's embedding space (image loss 'clip-text', paper eq. clip) while the smoothing cost
keeps it a rapid, human-like ΣΛ motion.

Artifacts: plan.json, drawing.svg, drawing.png, overlay.png (start in grey, result in
colour), speed.png, trajectory.csv, init.json and init.png (the start plan), plus job.json,
report.json and recording.rrd from the shell. The implementation is in
:mod:`inkmotion.generation.run`; importing this module imports no torch.
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

DEFAULT_CAPTION = "{word}, a stylish graffiti tag"


@dataclass
class TagParams(GenerationParams):
    """Parameters of a tag (the shared ones are :class:`GenerationParams`)."""

    caption: str = param(DEFAULT_CAPTION, "Caption CLIP matches; {word} is replaced by the word.")
    initialiser: PluginChoice = plugin_param("initialiser", "line", "Initialiser plugin.")
    losses: list[PluginChoice] = plugin_param("image-loss", "clip-text",
                                              "Image-loss plugin (repeatable).", many=True,
                                              flag="--loss")

    def validate(self) -> None:
        super().validate()
        if not self.losses:
            raise SpecError("The tag job needs at least one image loss (e.g. --loss clip-text).")


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
        from inkmotion.generation.run import run_tag

        return run_tag(job)


@hookimpl
def inkmotion_job_kinds() -> list:
    return [TagKind()]
