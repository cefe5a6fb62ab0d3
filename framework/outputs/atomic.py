"""Atomic outputs: a staging directory renamed into place.

A job writes its artifacts into ``DIR.partial-<random>`` next to the final ``DIR``;
:meth:`StagingDir.commit` then renames it into place, so a reader sees either the old
complete ``DIR`` or the new complete one, never a half-written one. Replacing an
existing ``DIR`` is two renames (``DIR -> DIR.old-<random>``, staging ``-> DIR``) and the
removal of the old copy; POSIX has no portable exchange of two directories, so between
the renames ``DIR`` is briefly absent (never partial). On an exception inside the
``with`` block the staging directory is removed and ``DIR`` is left untouched.
"""

from __future__ import annotations

import os
import secrets
import shutil
from pathlib import Path
from types import TracebackType


def _sibling(final: Path, tag: str) -> Path:
    return final.with_name(f"{final.name}.{tag}-{secrets.token_hex(4)}")


class StagingDir:
    """``with StagingDir(final) as stage:`` write into ``stage.path``; committed on a
    clean exit (or earlier by :meth:`commit`), discarded on an exception or :meth:`abort`."""

    def __init__(self, final: str | Path) -> None:
        self.final = Path(final)
        self.path: Path | None = None
        self.committed = False

    def __enter__(self) -> StagingDir:
        self.final.parent.mkdir(parents=True, exist_ok=True)
        self.path = _sibling(self.final, "partial")
        self.path.mkdir()
        return self

    def commit(self) -> Path:
        """Move the staging directory to ``final`` (replacing it); returns ``final``."""
        assert self.path is not None, "commit() outside the with block"
        if self.committed:
            return self.final
        old = None
        if self.final.exists():
            old = _sibling(self.final, "old")
            os.replace(self.final, old)
        try:
            os.replace(self.path, self.final)
        except BaseException:
            if old is not None:
                os.replace(old, self.final)  # put the previous version back
            raise
        self.committed = True
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        return self.final

    def abort(self) -> None:
        """Remove the staging directory; ``final`` is left as it was."""
        if self.path is not None and not self.committed:
            shutil.rmtree(self.path, ignore_errors=True)
            self.aborted = True

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None and not getattr(self, "aborted", False):
            try:
                self.commit()
            except BaseException:
                self.abort()
                raise
        elif exc_type is not None:
            self.abort()


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a sibling temporary file renamed into place, so
    ``path`` is either its old content or the whole new one, never a partial file."""
    path = Path(path)
    tmp = _sibling(path, "partial")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
