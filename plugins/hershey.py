"""Reader "text": ``text:WORD`` rendered with a built-in Hershey single-line script font.

The declaration only (sources starting with ``text:``, the font and letter spacing it
uses); the rendering and the joining of cursive runs are :mod:`inkmotion.inputs.hershey`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inkmotion.geometry.traces import Traces
from inkmotion.inputs.hershey import FONT, LETTER_SPACING, SCHEME, render_text
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import Reader


class HersheyTextReader:
    """Renders ``text:WORD`` with a Hershey script font, one stroke per pen-down polyline."""

    name = "text"
    description = "text:WORD rendered with a built-in Hershey single-line script font."

    def __init__(self, font: str = FONT, spacing: float = LETTER_SPACING) -> None:
        self.font = font
        self.spacing = spacing

    def can_read(self, source: str) -> bool:
        """True for sources of the form ``text:WORD``."""
        return source.startswith(SCHEME)

    def read(self, source: str) -> Traces:
        """Render the word after ``text:`` (:func:`inkmotion.inputs.hershey.render_text`);
        empty or unsupported text raises InputError."""
        return render_text(
            source[len(SCHEME) :], source=source, font=self.font, spacing=self.spacing
        )


@hookimpl
def inkmotion_readers() -> list[Reader]:
    """Register the Hershey text reader."""
    return [HersheyTextReader()]
