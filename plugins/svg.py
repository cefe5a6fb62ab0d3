"""Reader "svg": SVG paths and basic shapes, transforms honoured, one stroke per subpath.

The declaration only (files ending in ``.svg``, or ``.svgz`` compressed); parsing and curve
flattening are :mod:`inkmotion.inputs.svg`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from inkmotion.geometry.traces import Traces
from inkmotion.inputs.svg import read_svg
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import Reader


class SvgReader:
    """Reads SVG files (paths and basic shapes, transforms honoured) into traces."""

    name = "svg"
    description = ("SVG paths and shapes (.svg, .svgz), transforms honoured, one stroke per "
                   "subpath.")

    def can_read(self, source: str) -> bool:
        """True for paths ending in ``.svg`` or ``.svgz`` (gzip-compressed)."""
        return Path(source).suffix.lower() in (".svg", ".svgz")

    def read(self, source: str) -> Traces:
        """Parse ``source`` (:func:`inkmotion.inputs.svg.read_svg`); every malformed or
        degenerate input raises :class:`InputError`."""
        return read_svg(source)


@hookimpl
def inkmotion_readers() -> list[Reader]:
    """Register the SVG reader."""
    return [SvgReader()]
