"""What an input source string names: a file path or a ``scheme:value`` (``text:hello``).

Pure string tests, so the CLI, the job specs and the readers agree on which sources are
files to look for and which are values a reader renders itself. ``sample:NAME`` is a scheme
too: :func:`inkmotion.samples.locate` turns it into the file that ships with inkmotion.
"""

from __future__ import annotations


def is_scheme(source: str) -> bool:
    """True for ``scheme:value`` sources such as ``text:hello`` (a drive letter is not one)."""
    head, sep, _ = source.partition(":")
    return bool(sep) and len(head) > 1 and head.isidentifier()
