"""The ``inkmotion`` command of vpype (an entry point of the ``vpype.plugins`` group):
``vpype inkmotion PLAN.json ...`` reads a plan's trajectories into the pipeline, one layer
per pen (plan.json's optional ``"pen"`` per path, else layer 1), the page set to the canvas,
so vpype's own commands (linesort, layout, scaleto, write, gwrite) work on it. Geometry
only: the ΣΛ timing is what ``inkmotion run plot`` writes into G-code."""

from __future__ import annotations

import click
import vpype as vp
import vpype_cli


@click.command()
@click.argument("plan", type=click.Path(dir_okay=False))
@click.option("-s", "--spacing", type=vpype_cli.LengthType(), default="0.25",
              help="Longest chord between samples, in canvas px (or a length: 0.1mm).")
@click.option("-w", "--width", type=vpype_cli.LengthType(), default=None,
              help="Scale the canvas to this width (e.g. 18cm); default 1 canvas px = 1 px.")
@vpype_cli.global_processor
def inkmotion(document: vp.Document, plan: str, spacing: float, width: float | None
              ) -> vp.Document:
    """Read an inkmotion plan.json (a motor plan) as lines, one layer per pen.

    Example: vpype inkmotion plan.json linesort layout a4 write plot.svg
    """
    from inkmotion.errors import InputError
    from inkmotion.kinds.plot import plan_pens
    from inkmotion.plotter.lines import plan_polylines
    from inkmotion.sigma_lognormal import Drawing

    try:
        drawing = Drawing.load(plan)
        pens = plan_pens(plan, len(drawing.plans))
    except (InputError, OSError) as exc:
        raise click.BadParameter(str(exc), param_hint="PLAN") from exc
    scale = 1.0 if width is None else width / drawing.canvas[0]
    for pen, line in zip(pens, plan_polylines(drawing, spacing / scale), strict=True):
        points = scale * (line[:, 0] + 1j * line[:, 1])
        document.add(vp.LineCollection([points]), pen)
    document.page_size = (scale * drawing.canvas[0], scale * drawing.canvas[1])
    return document


inkmotion.help_group = "Input"
