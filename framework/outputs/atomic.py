"""Atomic outputs: a staging directory renamed into place.

A job writes its artifacts into ``DIR.partial-<random>`` next to the final ``DIR``;
:meth:`StagingDir.commit` then renames it into place, so a reader sees either the old
complete ``DIR`` or the new complete one, never a half-written one. Replacing an
existing ``DIR`` is two renames (``DIR -> DIR.old-<random>``, staging ``-> DIR``) and the
removal of the old copy; POSIX has no portable exchange of two directories, so between
the renames ``DIR`` is briefly absent (never partial). On an exception inside the
``with`` block the staging directory is removed and ``DIR`` is left untouched.

A process killed outright (SIGKILL, a machine's power) cannot clean up: its staging
folder is named after its host and process (``DIR.partial-<host>-<pid>-<random>``), and
the next job writing to ``DIR`` removes the ones whose process is gone from this host.
"""

from __future__ import annotations

import glob
import os
import re
import secrets
import shutil
import socket
from pathlib import Path
from types import TracebackType


def _sibling(final: Path, tag: str) -> Path:
    return final.with_name(f"{final.name}.{tag}-{secrets.token_hex(4)}")


def _owner_tag() -> str:
    """``<host>-<pid>`` of this process: the host's name without dashes or dots, and the
    inode of its PID namespace where Linux has one (containers that share a host name
    and a volume each see only their own processes: a live job of another namespace
    must never look dead)."""
    host = re.sub(r"[^A-Za-z0-9]", "", socket.gethostname()) or "host"
    try:
        host += f"ns{os.stat('/proc/self/ns/pid').st_ino}"
    except OSError:
        pass
    return f"{host}-{os.getpid()}"


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this host (one we may not signal counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


def remove_stale_staging(final: Path) -> list[Path]:
    """Remove the staging folders ``FINAL.partial-<host>-<pid>-<random>`` of processes of
    this host (and PID namespace) that no longer run (killed before they could clean
    up); return them. Another host's or namespace's, a running process's and an unnamed
    owner's are left alone."""
    host, _ = _owner_tag().rsplit("-", 1)
    removed = []
    for folder in final.parent.glob(f"{glob.escape(final.name)}.partial-*"):
        owner = folder.name[len(final.name) + len(".partial-"):].split("-")
        if (len(owner) == 3 and owner[0] == host and owner[1].isdigit()
                and int(owner[1]) != os.getpid() and not _alive(int(owner[1]))):
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


class StagingDir:
    """``with StagingDir(final) as stage:`` write into ``stage.path``; committed on a
    clean exit (or earlier by :meth:`commit`), discarded on an exception or :meth:`abort`.

    ``replace=False``: results already in ``final`` when it commits (another run's, which
    committed there while this one ran) are kept, and this run's go to the first free
    ``FINAL-2``, ``FINAL-3``, … instead; ``diverted_from`` is then the folder asked for and
    ``final`` the one used."""

    def __init__(self, final: str | Path, replace: bool = True) -> None:
        self.final = Path(final)
        self.replace = replace
        self.diverted_from: Path | None = None
        self.path: Path | None = None
        self.committed = False

    def __enter__(self) -> StagingDir:
        self.final.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_staging(self.final)
        self.path = _sibling(self.final, f"partial-{_owner_tag()}")
        self.path.mkdir()
        return self

    def commit(self) -> Path:
        """Move the staging directory to ``final`` (replacing it); returns ``final``."""
        assert self.path is not None, "commit() outside the with block"
        if self.committed:
            return self.final
        if not self.replace:
            return self._commit_beside()
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

    def _commit_beside(self) -> Path:
        """Move the staging directory to ``final`` unless that holds something (rename
        fails on a folder that is not empty: no window between a check and the move),
        else to the first free ``FINAL-N``."""
        assert self.path is not None
        wanted, k = self.final, 1
        while True:
            target = wanted if k == 1 else wanted.with_name(f"{wanted.name}-{k}")
            try:
                os.rename(self.path, target)
                break
            except OSError:
                if not target.exists():
                    raise
                k += 1
        if target != wanted:
            self.diverted_from, self.final = wanted, target
        self.committed = True
        return target

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
