"""A plotter program: the strokes as machine blocks (travel, pen, dwell, draw), the one
form both the G-code writer (:mod:`.gcode`) and the time estimate (:mod:`.planner`) read.
The machine starts and ends at X0 Y0 with the pen up."""

from __future__ import annotations

from dataclasses import dataclass

from inkmotion.plotter.machine import Machine
from inkmotion.plotter.timing import PlotStroke


@dataclass(frozen=True)
class Block:
    """One machine action: ``draw`` (G1 to ``xy`` at ``feed`` mm/s), ``travel`` (G0 to
    ``xy``), ``pen_down`` / ``pen_up``, ``dwell`` (``seconds``)."""

    kind: str
    xy: tuple[float, float] | None = None
    feed: float = 0.0
    seconds: float = 0.0


def build_program(strokes: list[PlotStroke], machine: Machine) -> list[Block]:
    """The blocks that draw ``strokes`` in order, from and back to X0 Y0."""
    blocks: list[Block] = []
    for st in strokes:
        blocks.append(Block("travel", tuple(st.points[0])))
        blocks += [Block("pen_down"), Block("dwell", seconds=machine.dwell_down_s)]
        for xy, feed in zip(st.points[1:], st.feeds, strict=True):
            blocks.append(Block("draw", tuple(xy), feed=float(feed)))
        blocks += [Block("pen_up"), Block("dwell", seconds=machine.dwell_up_s)]
    blocks.append(Block("travel", (0.0, 0.0)))
    return blocks

