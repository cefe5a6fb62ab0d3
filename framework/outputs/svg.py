"""drawing.svg: the trajectories as SVG 1.1 cubic Béziers.

A 2-D trajectory's segments (S, 4, 2) are one ``<path>``, ``M p0 C c1 c2 p3 C ...``
(consecutive segments share their end points), stroked with the trajectory's width in px.
A 3-D trajectory's segments (S, 4, 3) carry the stroke radius in px (the 2.5D plans of
DESIGN.md), which SVG cannot vary along one path: they become a ``<g>`` of one ``<path>``
per segment, ``M p0 C c1 c2 p3``, with stroke-width = 2·(r(P0) + r(P3))/2, twice the mean
radius of the segment's two end points. The round caps and joins of the
enclosing group make consecutive pieces meet without gaps (each cap is a disc of the
piece's half-width at the shared point). Everything is stroked black, no fill. The
document is ``width × height`` px with viewBox = canvas, so Inkscape and vpype read the
same size in px.
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


def segment_widths(segments: torch.Tensor) -> list[float]:
    """Stroke width of each 3-D segment (S, 4, 3): r(P0) + r(P3), twice the mean radius of
    its end points, clamped at 0."""
    r = segments.detach().to("cpu", torch.float64)[:, :, 2]  # (S, 4)
    return (r[:, 0] + r[:, 3]).clamp(min=0).tolist()


def _varying_group(i: int, segments: torch.Tensor) -> str:
    """``<g>`` of one ``<path>`` per 3-D segment, each with its own stroke-width."""
    seg = segments.detach().to("cpu", torch.float64).tolist()
    lines = [f'<g id="path{i}">\n']
    for k, (s, width) in enumerate(zip(seg, segment_widths(segments), strict=True)):
        d = f"M {_num(s[0][0])} {_num(s[0][1])} {_cubic(s)}"
        lines.append(f'<path id="path{i}-{k}" stroke-width={quoteattr(_num(width))} '
                     f'd="{d}"/>\n')
    lines.append("</g>\n")
    return "".join(lines)


def write_svg(
    path: str | Path,
    segments_per_path: list[torch.Tensor],
    widths: list[float],
    canvas: tuple[float, float],
) -> None:
    """Write each trajectory's segments, (S, 4, 2) as one ``<path>`` of width ``widths[i]``,
    or (S, 4, 3) as a ``<g>`` of per-segment paths whose width follows the radius (the
    widths entry is then ignored); ``canvas`` = (width, height) in px."""
    assert len(segments_per_path) == len(widths), (len(segments_per_path), len(widths))
    w, h = (_num(float(c)) for c in canvas)
    lines = [_HEADER.format(w=w, h=h)]
    for i, (seg, width) in enumerate(zip(segments_per_path, widths, strict=True)):
        if seg.shape[0] and seg.shape[-1] == 3:
            lines.append(_varying_group(i, seg))
            continue
        d = path_data(seg)
        if d:
            lines.append(
                f'<path id="path{i}" stroke-width={quoteattr(_num(float(width)))} d="{d}"/>\n'
            )
    lines.append("</g>\n</svg>\n")
    Path(path).write_text("".join(lines), encoding="utf-8")
