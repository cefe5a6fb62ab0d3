"""Paper for a plotter: sizes by name or ``WxH`` mm, orientation, and where the canvas
goes on it (:class:`inkmotion.robot.calibration.PaperMapping`, unit-agnostic: here mm)."""

from __future__ import annotations

import re

from inkmotion.errors import InputError
from inkmotion.robot.calibration import PaperMapping

#: portrait sizes, mm
PAPER_SIZES = {"A5": (148.0, 210.0), "A4": (210.0, 297.0), "A3": (297.0, 420.0),
               "letter": (215.9, 279.4)}


def paper_size(text: str, orientation: str, canvas: tuple[float, float]
               ) -> tuple[float, float]:
    """(width, height) mm of ``text`` (A5, A4, A3, letter or ``WxH`` in mm) turned to
    ``orientation``: portrait, landscape, or auto (a named size the way the canvas is, a
    ``WxH`` size as written)."""
    if orientation not in ("portrait", "landscape", "auto"):
        raise InputError(f"--orientation {orientation!r}: use portrait, landscape or auto.")
    named = {k.lower(): v for k, v in PAPER_SIZES.items()}.get(text.strip().lower())
    if named is None:
        match = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?)\s*[xX×]\s*([0-9]+(?:\.[0-9]*)?)"
                             r"\s*(?:mm)?\s*", text)
        size = (float(match.group(1)), float(match.group(2))) if match else (0.0, 0.0)
        if min(size) <= 0:
            raise InputError(f"--paper {text!r} is not a paper size; use A5, A4, A3, letter "
                             "or WIDTHxHEIGHT in mm (e.g. 300x200).")
        if orientation == "auto":
            return size
        named = size
    short, long_ = sorted(named)
    if orientation == "auto":
        orientation = "landscape" if canvas[0] > canvas[1] else "portrait"
    return (long_, short) if orientation == "landscape" else (short, long_)


def place_on_paper(canvas: tuple[float, float], paper: tuple[float, float], margin: float,
                   scale: float = 0.0) -> PaperMapping:
    """The canvas on the paper, centred: at ``scale`` mm/px when given (refused when it does
    not fit inside the margins), else the largest scale that fits."""
    w, h = paper
    if 2 * margin >= min(w, h):
        raise InputError(f"--margin {margin:g} mm leaves no room on {w:g} × {h:g} mm paper; "
                         "use a smaller margin.")
    fit = PaperMapping.from_canvas(canvas, paper, margin)
    if scale <= 0:
        return fit
    cw, ch = canvas
    if scale > fit.scale * (1 + 1e-9):
        raise InputError(
            f"the plan at --scale {scale:g} mm/px is {cw * scale:.1f} × {ch * scale:.1f} mm, "
            f"larger than the {w - 2 * margin:.1f} × {h - 2 * margin:.1f} mm inside the margins"
            f" of the paper; use --scale {fit.scale:.4g} or less, a larger --paper or a "
            "smaller --margin.")
    return PaperMapping(scale=scale, offset=((w - scale * cw) / 2, (h + scale * ch) / 2),
                        canvas=(float(cw), float(ch)), paper=(float(w), float(h)))
