"""drawing.svg: the trajectories as SVG 1.1 cubic Béziers.

A 2-D trajectory's segments (S, 4, 2) are one ``<path>``, ``M p0 C c1 c2 p3 C ...``
(consecutive segments share their end points), stroked with the trajectory's width in px.
A 3-D trajectory's segments (S, 4, 3) carry the stroke radius in px (the 2.5D plans of
2.5D plans), which an SVG stroke cannot vary along one path: a drawing with one is written
as brush outlines (:mod:`inkmotion.outputs.brush_svg`): a layer of filled regions, the
exact area each brush covers (a 2-D trajectory there is a brush of constant radius w/2),
and a layer of centre lines for pen plotters. Otherwise everything is stroked black, no
fill. The document is ``width × height`` px with viewBox = canvas, so Inkscape and vpype
read the same size in px.
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import torch

_HEADER = """<?xml version="1.0" encoding="UTF-8" standalone="no"?>
<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{w}px" height="{h}px" \
viewBox="0 0 {w} {h}">
<g fill="none" stroke="#000000" stroke-linecap="round" stroke-linejoin="round">
"""
_BRUSH_HEADER = """<?xml version="1.0" encoding="UTF-8" standalone="no"?>
<svg xmlns="http://www.w3.org/2000/svg" \
xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" version="1.1" \
width="{w}px" height="{h}px" viewBox="0 0 {w} {h}">
"""


def _num(v: float) -> str:
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0") else s


def _cubic(s: list[list[float]]) -> str:
    """``C x y x y x y`` of one segment's control points [[x, y, ...] × 4] (P1..P3)."""
    return "C " + " ".join(f"{_num(p[0])} {_num(p[1])}" for p in s[1:])


def path_data(segments: torch.Tensor) -> str:
    """SVG path data ``M x y C x y x y x y ...`` of cubic segments (S, 4, ≥2)."""
    seg = segments.detach().to("cpu", torch.float64)[..., :2].tolist()
    if not seg:
        return ""
    parts = [f"M {_num(seg[0][0][0])} {_num(seg[0][0][1])}"]
    parts.extend(_cubic(s) for s in seg)
    return " ".join(parts)


def _with_radius(segments: torch.Tensor, width: float) -> torch.Tensor:
    """2-D segments (S, 4, 2) as 3-D ones of constant radius width/2 (3-D: unchanged)."""
    if segments.shape[-1] == 3:
        return segments
    r = torch.full((*segments.shape[:2], 1), float(width) / 2, dtype=segments.dtype)
    return torch.cat((segments.detach().cpu(), r), dim=-1)


def write_svg(
    path: str | Path,
    segments_per_path: list[torch.Tensor],
    widths: list[float],
    canvas: tuple[float, float],
) -> None:
    """Write each trajectory's segments, (S, 4, 2) as one ``<path>`` of width ``widths[i]``;
    when one is (S, 4, 3) (its radius varies; the widths entry is then ignored), the brush
    outlines and centre lines instead (module docstring); ``canvas`` = (width, height) px."""
    assert len(segments_per_path) == len(widths), (len(segments_per_path), len(widths))
    w, h = (_num(float(c)) for c in canvas)
    if any(seg.shape[0] and seg.shape[-1] == 3 for seg in segments_per_path):
        from inkmotion.outputs.brush_svg import brush_layers

        brushes = [_with_radius(seg, width) for seg, width in
                   zip(segments_per_path, widths, strict=True)]
        lines = [_BRUSH_HEADER.format(w=w, h=h), *brush_layers(brushes, path_data),
                 "</svg>\n"]
        Path(path).write_text("".join(lines), encoding="utf-8")
        return
    lines = [_HEADER.format(w=w, h=h)]
    for i, (seg, width) in enumerate(zip(segments_per_path, widths, strict=True)):
        d = path_data(seg)
        if d:
            lines.append(
                f'<path id="path{i}" stroke-width={quoteattr(_num(float(width)))} d="{d}"/>\n'
            )
    lines.append("</g>\n</svg>\n")
    Path(path).write_text("".join(lines), encoding="utf-8")
