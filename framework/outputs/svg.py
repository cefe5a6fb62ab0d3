"""drawing.svg: one SVG 1.1 ``<path>`` of cubic Béziers per trajectory.

Each trajectory's segments (S, 4, 2) are written as ``M p0 C c1 c2 p3 C ...`` (consecutive
segments share their end points), stroked black, no fill, round caps and joins, with the
trajectory's width in px. The document is ``width × height`` px with viewBox = canvas, so
Inkscape and vpype read the same size in px.
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


def path_data(segments: torch.Tensor) -> str:
    """SVG path data ``M x y C x y x y x y ...`` of cubic segments (S, 4, ≥2)."""
    seg = segments.detach().to("cpu", torch.float64)[..., :2].tolist()
    if not seg:
        return ""
    parts = [f"M {_num(seg[0][0][0])} {_num(seg[0][0][1])}"]
    for s in seg:
        parts.append("C " + " ".join(f"{_num(x)} {_num(y)}" for x, y in s[1:]))
    return " ".join(parts)


def write_svg(
    path: str | Path,
    segments_per_path: list[torch.Tensor],
    widths: list[float],
    canvas: tuple[float, float],
) -> None:
    """Write one stroked ``<path>`` per trajectory; ``canvas`` = (width, height) in px."""
    assert len(segments_per_path) == len(widths), (len(segments_per_path), len(widths))
    w, h = (_num(float(c)) for c in canvas)
    lines = [_HEADER.format(w=w, h=h)]
    for i, (seg, width) in enumerate(zip(segments_per_path, widths, strict=True)):
        d = path_data(seg)
        if d:
            lines.append(
                f'<path id="path{i}" stroke-width={quoteattr(_num(float(width)))} d="{d}"/>\n'
            )
    lines.append("</g>\n</svg>\n")
    Path(path).write_text("".join(lines), encoding="utf-8")
