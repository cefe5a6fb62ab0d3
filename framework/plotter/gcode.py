"""G-code of a plotter program (:mod:`.program`) for a machine profile: G21/G90, G0 for
pen-up travel, the profile's pen commands and dwells, one ``G1 X Y F`` per segment with its
own feed (mm/min). Coordinates to the µm, feeds to four digits (:mod:`.resolution`);
comments on lines of their
own (``;``), so line-oriented readers see bare commands."""

from __future__ import annotations

from inkmotion.plotter.machine import Machine, gcode_words
from inkmotion.plotter.program import Block
from inkmotion.plotter.resolution import feed_text


def write_gcode(blocks: list[Block], machine: Machine, comments: list[str] = ()) -> str:
    """The G-code text of ``blocks`` on ``machine``, with ``comments`` at the top."""
    lines = [f"; {c}" for c in comments]
    words = gcode_words(machine.header)
    # millimetres and absolute coordinates, whatever a custom header left out
    lines += machine.header.splitlines() + [f"G{n}" for n in (21, 90)
                                            if ("G", float(n)) not in words]
    lines += machine.pen_up.splitlines()
    for b in blocks:
        if b.kind == "travel":
            lines.append(f"G0 X{b.xy[0]:.3f} Y{b.xy[1]:.3f}")
        elif b.kind == "draw":
            lines.append(f"G1 X{b.xy[0]:.3f} Y{b.xy[1]:.3f} F{feed_text(b.feed)}")
        elif b.kind == "pen_down":
            lines += machine.pen_down.splitlines()
        elif b.kind == "pen_up":
            lines += machine.pen_up.splitlines()
        elif b.kind == "dwell":
            if b.seconds > 0:
                lines.append(machine.dwell_line(b.seconds))
        else:  # pragma: no cover - the program is built here
            raise AssertionError(b.kind)
    lines += machine.footer.splitlines()
    return "\n".join(lines) + "\n"
