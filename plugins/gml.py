"""Reader "gml": Graffiti Markup Language tags, XML (spec 1.0), 000000book JSON and JSONP.

The declaration only: which sources it accepts (suffixes ``.gml``, ``.json``, ``.jsonp``,
``.js``, and ``.xml`` files whose root is ``<gml>``). The parsing, screen bounds, up vector
and time stamps are :mod:`inkmotion.inputs.gml`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from inkmotion.geometry.traces import Traces
from inkmotion.inputs.gml import read_gml
from inkmotion.inputs.sources import is_scheme
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.plugin_host.protocols import Reader

#: suffixes read as GML whatever the content; ``.xml`` is read when it holds ``<gml``
SUFFIXES = {".gml", ".json", ".jsonp", ".js"}


@dataclass
class GmlOptions:
    """Options of the 'gml' reader."""

    time_unit: str = param("auto", "The unit of the time stamps: 's', 'ms' or 'auto' (told "
                           "apart by the step between successive stamps: under 0.5 in "
                           "seconds, at least 0.5 in milliseconds).",
                           choices=("auto", "s", "ms"))


class GmlReader:
    """Reads GML tags (XML, 000000book JSON, JSONP) into traces in screen units, y down."""

    name = "gml"
    description = "GML graffiti tags: XML (spec 1.0), 000000book JSON and JSONP."
    Options = GmlOptions

    def can_read(self, source: str) -> bool:
        """True for ``.gml``/``.json``/``.jsonp``/``.js`` paths, and ``.xml`` files of GML."""
        if is_scheme(source) and not Path(source).exists():
            return False
        suffix = Path(source).suffix.lower()
        if suffix in SUFFIXES:
            return True
        if suffix == ".xml":
            try:
                with open(source, "rb") as fh:
                    head = fh.read(4096).lower()
            except OSError:
                return False
            return b"<gml" in head
        return False

    def read(self, source: str, time_unit: str = "auto") -> Traces:
        """Parse ``source`` (:func:`inkmotion.inputs.gml.read_gml`); every malformed or
        degenerate input raises :class:`InputError`."""
        return read_gml(source, time_unit)


@hookimpl
def inkmotion_readers() -> list[Reader]:
    """Register the GML reader."""
    return [GmlReader()]
