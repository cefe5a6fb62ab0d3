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
"""

from __future__ import annotations

import signal
from types import FrameType

#: the signals asked to stop this process, in order
_asked: list[str] = []


def _stop(signum: int, frame: FrameType | None) -> None:
    if signum == signal.SIGTERM:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _asked.append(signal.Signals(signum).name)
    raise KeyboardInterrupt


def install() -> None:
    """Handle SIGINT and SIGTERM as above (the command line's entry point calls it)."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _stop)


class StopWhenAsked:
    """A job observer that ends the job at its next step once a signal asked for it: the
    signal's own ``KeyboardInterrupt`` may have been swallowed where it landed."""

    def on_step(self, state: object) -> None:
        if _asked:
            raise KeyboardInterrupt
