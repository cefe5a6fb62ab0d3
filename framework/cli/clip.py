"""``inkmotion clip``: see which CLIP weights a job would use, and fetch them once.

The 'tag' and 'abstract' jobs never download anything: they use the weights in open_clip's
own cache (``--clip-weights auto``), a checkpoint file (``--clip-weights PATH``) or, for
tests only, random weights. ``inkmotion clip download`` is the one command that goes to the
network, on purpose, to fill open_clip's cache. open_clip and torch load inside the commands.
"""

from __future__ import annotations

from typing import Annotated

import typer
from rich.console import Console

from inkmotion.cli.errors import fail
from inkmotion.clip.weights import DEFAULT_MODEL as DEFAULT_CLIP_MODEL
from inkmotion.clip.weights import DEFAULT_PRETRAINED as DEFAULT_CLIP_PRETRAINED
from inkmotion.errors import InkmotionError

out = Console()
clip_app = typer.Typer(name="clip", help="CLIP weights: check what is available, download once.",
                       no_args_is_help=True, add_completion=False)

ModelOpt = Annotated[str, typer.Option("--model", help="open_clip model name.")]
PretrainedOpt = Annotated[str, typer.Option("--pretrained", help="open_clip pretrained tag.")]


@clip_app.command("status")
def status_cmd(model: ModelOpt = DEFAULT_CLIP_MODEL,
               pretrained: PretrainedOpt = DEFAULT_CLIP_PRETRAINED,
               weights: Annotated[str, typer.Option(
                   "--weights", help="auto, a checkpoint file, or random.")] = "auto") -> None:
    """Say whether a job with these CLIP settings can run offline (exit 1 when not); a
    checkpoint file is loaded into the model to be sure.

    Example: inkmotion clip status --model ViT-B-32 --pretrained laion2b_s34b_b79k
    """
    import warnings

    from inkmotion.clip.model import RANDOM_WARNING, load_clip, weights_problem
    from inkmotion.clip.weights import AUTO, RANDOM

    try:
        problem = weights_problem(model, pretrained, weights)
        if problem is None and weights not in (AUTO, RANDOM):
            with warnings.catch_warnings():  # a checkpoint file: does it load into the model?
                warnings.filterwarnings("ignore", message=RANDOM_WARNING)
                load_clip(model, pretrained, weights, "cpu")
    except InkmotionError as exc:
        fail(exc)
    if problem is not None:
        out.print(problem, highlight=False, soft_wrap=True)
        raise typer.Exit(1)
    note = (" (random weights: results are meaningless except for tests)"
            if weights == RANDOM else "")
    out.print(f"{model} ({pretrained}, weights {weights}): ready, no network needed{note}.",
              highlight=False)


@clip_app.command("download")
def download_cmd(model: ModelOpt = DEFAULT_CLIP_MODEL,
                 pretrained: PretrainedOpt = DEFAULT_CLIP_PRETRAINED) -> None:
    """Download a model's pretrained weights into open_clip's cache (needs the network once).

    Example: inkmotion clip download --model ViT-B-32 --pretrained laion2b_s34b_b79k
    """
    from inkmotion.clip.model import download_weights

    try:
        path = download_weights(model, pretrained)
    except InkmotionError as exc:
        fail(exc)
    out.print(f"{model} ({pretrained}) weights are in {path}; jobs use them with "
              "--clip-weights auto (the default).", highlight=False, soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Add the ``clip`` group to the ``inkmotion`` app."""
    app.add_typer(clip_app)
