"""``inkmotion trace IMAGE --out DIR``: the strokes a fit would find in a picture of a line
drawing, as SVG, GML and a PNG over the picture (:mod:`inkmotion.tracing.outputs`), to
check or correct before fitting."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.console import Console

from inkmotion.cli.errors import fail
from inkmotion.errors import InkmotionError, SpecError
from inkmotion.images.formats import PICTURE_FORMATS


def trace_cmd(
    ctx: typer.Context,
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
    fix strokes.svg or strokes.gml by hand if a stroke is wrong, and fit that file. A
    tracer plugin's own options follow as in `inkmotion run fit` (--TRACER-OPTION VALUE).

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
        chosen = plugin("tracer", tracer)
        options = tracer_options(chosen, ctx.args)
        traces, picture = trace_input(image, chosen, invert=invert, varying_width=True,
                                      **options)
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


def tracer_options(tracer: Any, args: list[str]) -> dict[str, Any]:
    """The keyword arguments ``--NAME-OPTION VALUE`` (``--[no-]NAME-OPTION`` for a switch)
    in ``args`` give ``tracer`` (named NAME), checked against its ``Options`` as a fit's
    are; anything else in ``args`` is refused in one sentence."""
    from inkmotion.jobs.params import PluginChoice, describe, options_dict, plugin_options
    from inkmotion.plugin_host.protocols import option_flag

    cls = getattr(tracer, "Options", None)
    infos = {option_flag(tracer.name, i.name): i
             for i in (describe(cls) if cls is not None else [])}
    raw: dict[str, Any] = {}
    words = list(args)
    while words:
        word = words.pop(0)
        flag, _, given = word.partition("=")
        switch_off = flag.startswith("--no-") and "--" + flag[5:] in infos
        info = infos.get("--" + flag[5:] if switch_off else flag)
        if info is None:
            known = ", ".join(infos) or "none"
            raise SpecError(f"trace takes no option {flag}; the {tracer.name} tracer's "
                            f"options are: {known} (`inkmotion trace --help`).")
        if info.type is bool:
            raw[info.name] = not switch_off
            continue
        if not given:
            if not words:
                raise SpecError(f"{flag} needs a value.")
            given = words.pop(0)
        try:
            raw[info.name] = info.type(given) if info.type in (int, float) else given
        except ValueError:
            raise SpecError(f"{flag}: {given!r} is not a number.") from None
    choice = PluginChoice("tracer", tracer.name, raw)
    return options_dict(plugin_options(tracer, choice, "inkmotion trace"))


def register(app: typer.Typer) -> None:
    """Add ``trace`` to the ``inkmotion`` app (a tracer's options ride in its extra
    arguments, as ``--NAME-OPTION``: :func:`tracer_options`)."""
    app.command("trace", context_settings={"allow_extra_args": True,
                                           "ignore_unknown_options": True})(trace_cmd)
