"""Text rendering: ``text:WORD`` drawn with a Hershey single-line script font (the 'text'
reader plugin wraps it).

Uses the ``HersheyFonts`` package (pip distribution ``Hershey-Fonts``), whose fonts are
built in, so a demo needs no data files. The default font is ``scripts`` (Hershey Script
Simplex, a connected cursive). Glyph coordinates are Hershey units, y down (cap line −12,
baseline 9); letters advance by their own widths plus ``LETTER_SPACING`` units. The
library splits a glyph into pen-down runs; runs that continue exactly where the previous
one ended (within a glyph and across joined cursive letters) are merged, so each stroke
is one connected pen-down polyline.
"""

from __future__ import annotations

import numpy as np

from inkmotion.errors import InputError
from inkmotion.geometry.traces import Traces

SCHEME = "text:"
#: Hershey font used for ``text:WORD`` (one of ``HersheyFonts().default_font_names``)
FONT = "scripts"
#: extra advance between letters, in Hershey units (a glyph is about 21 units tall)
LETTER_SPACING = 0.0
#: longest accepted text, in characters
MAX_CHARS = 200


def render_text(
    text: str, source: str | None = None, font: str = FONT, spacing: float = LETTER_SPACING
) -> Traces:
    """Render ``text`` as validated :class:`Traces` in Hershey units (y down)."""
    from HersheyFonts import HersheyFonts

    source = source or f"{SCHEME}{text}"
    if not text.strip():
        raise InputError(f"{source}: the text is empty; write a word after 'text:'.")
    if len(text) > MAX_CHARS:
        raise InputError(
            f"{source}: the text has {len(text)} characters, more than {MAX_CHARS}; "
            "use a shorter text."
        )
    fonts = HersheyFonts()
    if font not in fonts.default_font_names:
        raise InputError(
            f"{source}: unknown Hershey font {font!r}; choose one of "
            f"{', '.join(fonts.default_font_names)}."
        )
    fonts.load_default_font(font)
    missing = list(dict.fromkeys(c for c in text if c not in fonts.all_glyphs))  # as written
    if missing:
        shown = "".join(missing)
        raise InputError(
            f"{source}: the Hershey font {font!r} has no glyph for {shown!r}; "
            "use plain ASCII letters, digits and punctuation."
        )
    fonts.render_options.spacing = spacing
    runs = [np.asarray(r, dtype=np.float64) for r in fonts.strokes_for_text(text) if len(r)]
    strokes = merge_connected(runs)
    if not strokes:
        raise InputError(f"{source}: the text renders no lines (only spaces?); write a word.")
    return Traces(
        strokes, source=source, meta={"format": "text", "font": font, "text": text}
    ).validated()


def merge_connected(runs: list[np.ndarray], tol: float = 1e-9) -> list[np.ndarray]:
    """Join consecutive polylines where one starts at the previous one's end point."""
    merged: list[np.ndarray] = []
    for run in runs:
        if merged and np.all(np.abs(merged[-1][-1] - run[0]) <= tol):
            merged[-1] = np.vstack([merged[-1], run[1:]])
        else:
            merged.append(run)
    return merged
