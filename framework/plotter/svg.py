"""plot.svg: what the machine will draw, on the paper, in mm (1 user unit = 1 mm), one
Inkscape layer per pen (vpype ``read`` and Inkscape keep them apart). Machine Y runs up
from the paper's bottom-left corner, SVG y down from its top-left: y_svg = h − Y."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

from inkmotion.plotter.timing import PlotStroke


def write_plot_svg(path: Path, strokes: list[PlotStroke], paper: tuple[float, float],
                   pen_width_mm: float = 0.5) -> None:
    """Write ``strokes`` (drawing order) as polylines, a layer per pen."""
    w, h = paper
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<svg xmlns="http://www.w3.org/2000/svg" '
           f'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" '
           f'width="{w:g}mm" height="{h:g}mm" viewBox="0 0 {w:g} {h:g}">']
    for pen in sorted({st.pen for st in strokes}):
        out.append(f'<g inkscape:groupmode="layer" id="layer{pen}" '
                   f'inkscape:label={quoteattr(f"pen {pen}")} fill="none" stroke="black" '
                   f'stroke-width="{pen_width_mm:g}" stroke-linecap="round" '
                   'stroke-linejoin="round">')
        for st in strokes:
            if st.pen != pen:
                continue
            pts = st.points if len(st.points) > 1 else st.points[[0, 0]]
            coords = " ".join(f"{x:.3f},{h - y:.3f}" for x, y in pts)
            out.append(f'<polyline points="{coords}"/>')
        out.append("</g>")
    out.append("</svg>")
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
