"""Ctrl-C and SIGTERM (``kill``, ``timeout``, a container stopped) end a command alike:
a job's staging folder is removed and nothing half-written is left.

The first signal raises ``KeyboardInterrupt`` wherever the main thread is. A library may
swallow an exception raised inside it (rerun, converting an image, logs any error as a
warning and goes on), so a job run from the command line also carries
:class:`StopWhenAsked`, an observer that raises it again at the job's next step. A
repeated SIGTERM (``timeout``'s or a supervisor's) while the first one's clean-up runs is
ignored; a second Ctrl-C still cuts it short, as a person pressing it twice means. A
command that manages its own signals (a worker, the studio, a robot in motion) sets its
own handlers over these.

A command a signal ended exits with :data:`EXIT_INTERRUPTED` by :func:`exit_interrupted`,
not ``sys.exit``: CPython marks a ``KeyboardInterrupt`` raised inside code that a C
extension ran through its ``PyRun_*`` calls as unhandled even when Python code caught it,
and then kills itself with SIGINT at exit (status −2, not 130), which one run in a few
dozen of the SIGTERM test did.
"""

from __future__ import annotations

import os
import signal
import sys
from types import FrameType
from typing import NoReturn

#: the exit status of a command a signal ended (128 + SIGINT: what a shell reports for
#: Ctrl-C)
EXIT_INTERRUPTED = 130

#: whether a signal has asked this process to stop
_asked = False


def _stop(signum: int, frame: FrameType | None) -> None:
    global _asked
    if signum == signal.SIGTERM:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _asked = True
    raise KeyboardInterrupt


def install() -> None:
    """Handle SIGINT and SIGTERM as above (the command line's entry point calls it)."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _stop)


def exit_interrupted() -> NoReturn:
    """End the process with :data:`EXIT_INTERRUPTED` once its clean-up is done and said:
    stdout and stderr flushed, then ``os._exit`` (module docstring: why not ``sys.exit``).
    What atexit handlers would still do is not needed then: the job's staging folder,
    its recording in it, is already gone, and a benchmark's workers have been joined."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(EXIT_INTERRUPTED)


class StopWhenAsked:
    """A job observer that ends the job at its next step once a signal asked for it: the
    signal's own ``KeyboardInterrupt`` may have been swallowed where it landed."""

    def on_step(self, state: object) -> None:
        if _asked:
            raise KeyboardInterrupt
