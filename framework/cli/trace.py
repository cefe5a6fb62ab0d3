"""``inkmotion trace IMAGE --out DIR``: the strokes a fit would find in a picture of a line
drawing, as SVG, GML and a PNG over the picture (:mod:`inkmotion.tracing.outputs`), to
check or correct before fitting."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console

from inkmotion.cli.errors import fail
from inkmotion.errors import InkmotionError
from inkmotion.images.formats import PICTURE_FORMATS


def trace_cmd(
    image: Annotated[str, typer.Argument(help=f"A picture of a line drawing ({PICTURE_FORMATS}; "
                                              "HEIC with pillow-heif) or sample:NAME.")],
    out: Annotated[Optional[Path], typer.Option(  # noqa: UP045
        "--out", help="Folder to write strokes.svg, strokes.gml, strokes.png and "
                      "extraction.json into.")] = None,
    invert: Annotated[bool, typer.Option(
        "--invert", help="Light ink on dark paper (otherwise detected).")] = False,
    tracer: Annotated[str, typer.Option(help="Tracer plugin.")] = "skeleton",
    force: Annotated[bool, typer.Option("--force", help="Replace --out if it exists.")] = False,
) -> None:
    """Trace a picture's strokes (order, direction, width) without fitting.

    strokes.png shows each stroke numbered in drawing order, with an arrow where it ends;
    fix strokes.svg or strokes.gml by hand if a stroke is wrong, and fit that file.

    Examples:

      inkmotion trace sample:brush-scan --out results/scan-strokes

      inkmotion trace chalk_on_board.jpg --invert --out results/board

      inkmotion run fit results/scan-strokes/strokes.gml --out results/scan
    """
    if out is None:
        fail("give the folder to write: --out DIR.", code=2)
    from inkmotion.kinds.read import trace_input
    from inkmotion.outputs import StagingDir, refuse_to_overwrite
    from inkmotion.plugin_host import plugin
    from inkmotion.tracing.outputs import write_trace

    try:
        refuse_to_overwrite(out, force, inputs=[image])
        traces, picture = trace_input(image, plugin("tracer", tracer), invert=invert,
                                      varying_width=True)
        with StagingDir(out) as stage:
            assert stage.path is not None
            names = write_trace(traces, picture.grey, stage.path, picture.page)
    except InkmotionError as exc:
        fail(exc)
    ex = traces.meta.get("extraction", {})
    notes = "".join(f"; {n}" for n in ex.get("notes", []))
    Console(stderr=True).print(
        f"{image}: {ex.get('strokes')} strokes ({ex.get('junctions')} junctions, "
        f"{ex.get('loops')} loops, {ex.get('dots')} dots), ink "
        f"{ex.get('ink_width_px', {}).get('median', 0):.1f} px wide, traced in "
        f"{ex.get('seconds', 0):.2f} s{notes}\nresults in {out} ({', '.join(names)})",
        highlight=False)


def register(app: typer.Typer) -> None:
    """Add ``trace`` to the ``inkmotion`` app."""
    app.command("trace")(trace_cmd)
