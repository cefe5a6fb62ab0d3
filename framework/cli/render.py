"""``inkmotion render PLAN.json --out FILE.png``: re-render a saved plan at any size, as the
'raster' pen line or the seeded spray preview (:mod:`inkmotion.rendering.render_plan`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console

from inkmotion.cli.errors import fail
from inkmotion.errors import InkmotionError


def render_cmd(
    plan: Annotated[Path, typer.Argument(help="A plan.json (fit, tag or abstract job).")],
    out: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--out", help="The PNG to write.")] = None,
    renderer: Annotated[str, typer.Option(help="raster (the pen line) or spray (preview "
                                               "with particles and drips).")] = "raster",
    size: Annotated[int, typer.Option(help="Longer side of the image, px.")] = 1000,
    seed: Annotated[int, typer.Option(help="Seed of the spray particles and drips.")] = 0,
    colour: Annotated[str, typer.Option(help="Paint colour, #rrggbb.")] = "#141418",
    background: Annotated[str, typer.Option(help="Paper colour, #rrggbb.")] = "#ffffff",
    force: Annotated[bool, typer.Option("--force", help="Replace --out if it exists.")] = False,
) -> None:
    """Re-render a saved plan at any resolution (prints up to 16384 px).

    Examples:

      inkmotion render results/tag/plan.json --renderer spray --size 4000 --out tag-4k.png

      inkmotion render plan.json --renderer spray --seed 7 --colour "#c0162c" --out red.png

      inkmotion render plan.json --size 2000 --background "#f4efe4" --out print.png
    """
    if out is None:
        fail("give the image to write: --out FILE.png.", code=2)
    if out.suffix.lower() != ".png":
        fail(f"--out {out}: render writes PNG images; name the file *.png.", code=2)
    from inkmotion.outputs import refuse_to_overwrite
    from inkmotion.plugin_host import plugin
    from inkmotion.rendering.render_plan import check_options, render_plan

    try:
        check_options(renderer, size, colour, background)  # before a renderer loads torch
        refuse_to_overwrite(out, force, folder=False)
        raster = plugin("renderer", "raster") if renderer == "raster" else None
        figures = render_plan(plan, out, renderer=renderer, raster=raster, size=size,
                              seed=seed, colour=colour, background=background)
    except InkmotionError as exc:
        fail(exc)
    extra = f", {figures['drips']} drips" if "drips" in figures else ""
    Console(stderr=True).print(f"{out}: {figures['width']}×{figures['height']} px, "
                               f"{renderer}{extra}", highlight=False)


def register(app: typer.Typer) -> None:
    """Add ``render`` to the ``inkmotion`` app."""
    app.command("render")(render_cmd)
