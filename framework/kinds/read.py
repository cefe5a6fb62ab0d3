"""Read any supported input into traces by asking the registered reader plugins.

It lives among the kinds, not the engines, because it asks the plugin host for the
readers; the engines' part of a source, :func:`~inkmotion.inputs.sources.is_scheme`, is
pure and lives in :mod:`inkmotion.inputs.sources`. A ``sample:NAME`` source is read from the
file that ships with inkmotion (:func:`inkmotion.samples.locate`)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from inkmotion.errors import InputError
from inkmotion.geometry.traces import Traces
from inkmotion.inputs.sources import is_scheme
from inkmotion.plugin_host import host
from inkmotion.samples import locate


def read_input(source: str, reader: str | None = None) -> Traces:
    """Parse ``source`` (a file path, ``sample:NAME`` or ``scheme:value``) with the first
    reader that accepts it, or with the reader plugin named ``reader``.

    A ``sample:NAME`` source becomes its shipped file (an unknown name is refused with the
    list of samples). A path that does not exist (and is no ``scheme:value`` string) is
    refused before any reader runs. Readers are asked in name order (``can_read``), so the
    choice is deterministic; when none accepts the source the error lists the supported
    forms.
    """
    source = locate(source)
    if not is_scheme(source) and not Path(source).exists():
        raise InputError(f"{source}: no such file; check the path.")
    if reader is not None:
        return host().get("reader", reader).read(source)
    readers = host().plugins("reader")
    name = _first_reader(readers, source)
    if name is not None:
        return readers[name].read(source)
    forms = "; ".join(
        f"{name} ({readers[name].description.rstrip('.')})" for name in sorted(readers)
    )
    raise InputError(
        f"{source}: no reader accepts this input; supported forms are: {forms or 'none'}."
    )


def _first_reader(readers: dict[str, Any], source: str) -> str | None:
    """The name of the first reader, in name order, that accepts ``source``; None if
    none does."""
    return next((name for name in sorted(readers) if readers[name].can_read(source)), None)


def trace_input(source: str, tracer: Any, *, invert: bool = False,
                varying_width: bool = False, **options: Any) -> tuple[Traces, Any]:
    """The traces of the picture ``source`` (a path or ``sample:NAME``) through the
    ``tracer`` plugin object, and the decoded :class:`~inkmotion.tracing.Picture`: decoded
    (:func:`inkmotion.tracing.read_picture`, ``invert`` forcing light ink on dark paper),
    traced with ``options``, the whole time recorded as
    ``meta["extraction"]["seconds_with_decoding"]``. A source that a reader takes as
    strokes already (an SVG, a GML, ``text:``) is refused: there is nothing to trace."""
    from inkmotion.tracing import read_picture
    from inkmotion.tracing.picture import is_picture

    path = locate(source)
    if not is_picture(path):  # strokes already (an SVG, a GML, text:): nothing to trace
        taker = _first_reader(host().plugins("reader"), path)
        if taker is not None:
            raise InputError(f"{source}: a drawing's strokes already (the '{taker}' reader "
                             f"reads it), not a picture to trace; fit it as it is: "
                             f"inkmotion run fit {source}.")
    start = time.perf_counter()
    picture = read_picture(path, invert=invert)
    traces = tracer(picture, varying_width=varying_width, **options)
    traces.meta.setdefault("extraction", {})["seconds_with_decoding"] = round(
        time.perf_counter() - start, 4)
    return traces, picture
