"""Read any supported input into traces by asking the registered reader plugins.

It lives among the kinds, not the engines, because it asks the plugin host for the
readers; the engines' part of a source, :func:`~inkmotion.inputs.sources.is_scheme`, is
pure and lives in :mod:`inkmotion.inputs.sources`. A ``sample:NAME`` source is read from the
file that ships with inkmotion (:func:`inkmotion.samples.locate`)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inkmotion.errors import InputError, PluginError
from inkmotion.geometry.traces import Traces
from inkmotion.inputs.sources import is_scheme
from inkmotion.plugin_host import host
from inkmotion.samples import locate

if TYPE_CHECKING:
    from inkmotion.jobs.kind import ResolvedJob


def read_input(source: str, reader: str | None = None,
               options: dict[str, Any] | None = None) -> Traces:
    """Parse ``source`` (a file path, ``sample:NAME`` or ``scheme:value``) with the first
    reader that accepts it, or with the reader plugin named ``reader`` (its ``options``
    as keyword arguments of its ``read``).

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
        return _traces_of(host().get("reader", reader), source, options or {})
    readers = host().plugins("reader")
    name = _first_reader(readers, source)
    if name is not None:
        return _traces_of(readers[name], source, {})
    forms = "; ".join(
        f"{name} ({readers[name].description.rstrip('.')})" for name in sorted(readers)
    )
    raise InputError(
        f"{source}: no reader accepts this input; supported forms are: {forms or 'none'}."
    )


def _traces_of(reader: Any, source: str, options: dict[str, Any]) -> Traces:
    """``reader.read(source, **options)``, held to the Reader protocol: Traces."""
    traces = reader.read(source, **options)
    if not isinstance(traces, Traces):
        raise PluginError(f"The reader plugin {reader.name!r} returned "
                          f"{type(traces).__name__} for {source}; read() must return "
                          f"inkmotion.geometry.traces.Traces.")
    return traces


def _first_reader(readers: dict[str, Any], source: str) -> str | None:
    """The name of the first reader, in name order, that accepts ``source``; None if
    none does. A reader whose ``can_read`` raises (a plugin's bug, e.g. opening a
    ``text:`` source as a file) is taken as declining, with a warning naming it: one
    broken reader must not stop the others from reading what they can."""
    import warnings

    for name in sorted(readers):
        try:
            if readers[name].can_read(source):
                return name
        except Exception as exc:
            origin = getattr(readers[name], "_inkmotion_origin", "?")
            warnings.warn(f"the reader plugin {name!r} from {origin} failed to answer whether "
                          f"it reads {source} ({type(exc).__name__}: {exc}); it was skipped; "
                          f"its can_read must return False for what it cannot read.",
                          stacklevel=2)
    return None


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


def check_plan_input(job: ResolvedJob, name: str = "plan") -> None:
    """Refuse, with the sentence the run would give, input ``name`` of ``job`` when it is
    not a plan.json inkmotion can read (a job kind's ``check_inputs``)."""
    from inkmotion.sigma_lognormal import Drawing

    Drawing.load(locate(job.spec.inputs[name]))


def check_photo_input(job: ResolvedJob, name: str = "image") -> None:
    """Refuse, with the sentence the run would give, input ``name`` of ``job`` when it is
    not a picture inkmotion can read, or a blank one at the job's ``size`` (a job kind's
    ``check_inputs``)."""
    from inkmotion.images.load import load_image

    load_image(locate(job.spec.inputs[name]), job.params.size)
