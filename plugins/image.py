"""Pictures of line drawings: the tracer "skeleton" and the reader "image".

The declarations only. The tracer turns a decoded picture into strokes through its
skeleton (:mod:`inkmotion.tracing.strokes`); the reader accepts picture files by suffix
and traces them with the same method at its defaults (dark ink detected against the
paper), so every command that reads a drawing reads a picture too. A fit reads pictures
itself to honour ``--invert``, ``--varying-width`` and ``--tracer``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from inkmotion.images.formats import PICTURE_FORMATS
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.geometry.traces import Traces
    from inkmotion.plugin_host.protocols import Reader, Tracer
    from inkmotion.tracing.picture import Picture


class SkeletonTracer:
    """Strokes from the ink's skeleton: straight through crossings, turning at corners,
    begun top-left, ordered in lines (:mod:`inkmotion.tracing.strokes`)."""

    name = "skeleton"
    description = ("Centrelines of the ink (scikit-image skeleton and pixel graph): strokes "
                   "straight through crossings, in writing order, with the ink's width.")

    def __call__(self, picture: Picture, *, varying_width: bool = False,
                 **options: Any) -> Traces:
        """:func:`inkmotion.tracing.trace_picture` (it takes no options)."""
        from inkmotion.errors import SpecError
        from inkmotion.tracing import trace_picture

        if options:
            raise SpecError(f"the skeleton tracer takes no options (got "
                            f"{', '.join(sorted(options))}); remove -p tracer.… from the job.")
        return trace_picture(picture, varying_width=varying_width)


class ImageReader:
    """Reads pictures of line drawings (:mod:`inkmotion.images.formats`; HEIC with
    pillow-heif) into traces."""

    name = "image"
    description = (f"Pictures of line drawings ({PICTURE_FORMATS}): dark ink on light "
                   "paper, or light on dark (detected), traced by 'skeleton'.")

    def can_read(self, source: str) -> bool:
        """True for paths with a picture's suffix."""
        from inkmotion.tracing.picture import is_picture

        return is_picture(source)

    def read(self, source: str) -> Traces:
        """Decode and trace ``source`` (:mod:`inkmotion.tracing`)."""
        from inkmotion.tracing import read_picture, trace_picture

        return trace_picture(read_picture(source))


@hookimpl
def inkmotion_tracers() -> list[Tracer]:
    """Register the skeleton tracer."""
    return [SkeletonTracer()]


@hookimpl
def inkmotion_readers() -> list[Reader]:
    """Register the image reader."""
    return [ImageReader()]
