"""Checks every file reader makes before parsing: it exists, is not empty, is not huge."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from inkmotion.errors import InputError

#: readers refuse input files larger than this
MAX_FILE_BYTES = 50 * 1024 * 1024


def missing_file(source: str, what: str = "drawing") -> str | None:
    """The sentence saying why ``source`` is not a file to read (a folder, or nothing at
    that path), or None when it is one; ``what`` names the input (the drawing, a plan)."""
    import os

    path = Path(source)
    if path.is_dir():
        return f"{source}: is a folder, not a file; give the {what}'s file."
    if not path.is_file():
        if os.path.lexists(source):  # a pipe, a device, a link to one or to nothing
            return (f"{source}: is not a regular file (a pipe, a device, or a link that "
                    f"leads to none); give the {what}'s file.")
        return f"{source}: no such file; check the path."
    return None


def checked_input_file(source: str, holds: str, limit: int | None = None) -> Path:
    """The path of ``source`` after the common checks; ``holds`` completes the empty-file
    hint ("give a GML file that holds {holds}"). ``limit`` overrides MAX_FILE_BYTES."""
    path = Path(source)
    limit = MAX_FILE_BYTES if limit is None else limit
    problem = missing_file(source)
    if problem is not None:
        raise InputError(problem)
    size = path.stat().st_size
    if size > limit:
        raise InputError(
            f"{source}: the file is {size / 2**20:.0f} MB, more than the "
            f"{limit // 2**20} MB limit; simplify the drawing or split it."
        )
    if size == 0:
        raise InputError(f"{source}: the file is empty; give a file that holds {holds}.")
    return path


@contextmanager
def reader_boundary(source: str, what: str, hint: str) -> Iterator[None]:
    """The edge of a reader: any error other than :class:`InputError` inside becomes one
    sentence naming ``source`` ("the {what} could not be read (...); {hint}")."""
    try:
        yield
    except InputError:
        raise
    except RecursionError as exc:  # a document nested thousands of levels deep
        raise InputError(f"{source}: the {what} is nested too deeply to read (thousands of "
                         f"levels of groups or references); {hint}") from exc
    except Exception as exc:  # no raw parser error escapes a reader
        raise InputError(
            f"{source}: the {what} could not be read ({type(exc).__name__}: {exc}); {hint}"
        ) from exc
