"""The terminal progress bar of ``inkmotion run``, an observer like the others.

Beside the step count the bar shows what the kind says of the step
(:meth:`inkmotion.events.StepState.shown`): an optimisation's total loss, T_end and loss
terms, or another kind's own figures (simulate: the stage and the drawing's duration;
evaluate: the path and the timing being computed; ...). Values still on the device (0-d
tensors) are read only every ``refresh_s`` seconds, in one transfer, so the bar costs no
GPU synchronisation on most steps; plain numbers and texts are shown at every step. The
bar is cleared once the last step is done, before the kind or the command prints its
results. Written to stderr, so stdout stays clean for scripts. Where stderr is not a
terminal (a log file, CI, a pipe), a bar redrawn in place would be one endless line of
carriage returns: a plain line is written instead at every tenth of the run (and at its
last step), each read of the device's values made there.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from typing import Any

from inkmotion.events import RunContext, StepState, scalars

#: count, a short bar, elapsed<remaining, then the kind's figures: at 80 columns most of
#: the line is left to the figures (tqdm cuts the line at the terminal's width)
BAR_FORMAT = "{desc}: {n_fmt}/{total_fmt} {bar:10} {elapsed}<{remaining}{postfix}"


def format_figures(values: dict[str, Any]) -> str:
    """``name=value, ...``: texts as they are, numbers (and 0-d tensors, read here in one
    transfer) to 4 significant digits."""
    numbers = scalars({k: v for k, v in values.items() if not isinstance(v, str)})
    return ", ".join(f"{k}={v}" if isinstance(v, str) else f"{k}={numbers[k]:.4g}"
                     for k, v in values.items())


#: a log (stderr not a terminal) gets a line at every this share of the run
LOG_EVERY = 0.1


@dataclass
class _Log:
    """Plain mode's state: what to call the run, its steps, when it began (monotonic s)
    and the share of the run at which the next line is due."""

    desc: str
    total: int
    start: float
    next: float = 0.0


class ProgressBar:
    """A tqdm bar over the job's steps, showing what the kind reports of each step; or,
    with ``plain`` (default: when stderr is not a terminal), a line at every
    :data:`LOG_EVERY` of the run."""

    def __init__(self, desc: str = "", refresh_s: float = 0.5,
                 plain: bool | None = None) -> None:
        self.desc = desc
        self.refresh_s = refresh_s
        self.plain = plain
        self._bar: Any = None
        self._shown = -math.inf  # the first step is shown
        self._log: _Log | None = None  # plain mode
        self._last: StepState | None = None  # the latest step's state

    def on_start(self, ctx: RunContext) -> None:
        desc = self.desc or ctx.spec.kind
        plain = self.plain if self.plain is not None else not sys.stderr.isatty()
        if plain:
            self._log = _Log(desc, ctx.total_steps, time.monotonic())
            return
        from tqdm.auto import tqdm

        self._bar = tqdm(total=ctx.total_steps, desc=desc, unit="step",
                         dynamic_ncols=True, leave=False, bar_format=BAR_FORMAT)

    def _log_line(self, state: StepState, ended: bool = False) -> None:
        """Plain mode: a line when the run has passed its next tenth, or at its end
        (``ended``: the job ended at this step, before the total it announced)."""
        log = self._log
        assert log is not None
        total = state.step if ended else state.total or log.total or 0
        last = bool(total) and state.step >= total
        share = state.step / total if total else 0.0
        if not last and share < log.next:
            return
        log.next = (math.floor(share / LOG_EVERY) + 1) * LOG_EVERY
        elapsed = time.monotonic() - log.start
        count = f"{state.step}/{total}" if total else f"{state.step}"
        figures = format_figures(state.shown())
        print(f"{log.desc}: {count} {elapsed:.1f} s" + (f", {figures}" if figures else ""),
              file=sys.stderr, flush=True)
        if last:
            self._log = None

    def on_step(self, state: StepState) -> None:
        self._last = state
        if self._log is not None:
            self._log_line(state)
            return
        if self._bar is None:
            return
        if state.total and state.total != self._bar.total:  # a kind that counts as it goes
            self._bar.total = state.total
        last = bool(state.total) and state.step >= state.total
        values = state.shown()
        on_host = not any(hasattr(v, "detach") for v in values.values())  # free to read
        now = time.monotonic()
        if on_host or last or now - self._shown >= self.refresh_s:
            self._shown = now
            self._bar.set_postfix_str(format_figures(values), refresh=False)
        self._bar.update(max(0, state.step - self._bar.n))  # a resumed job starts past 0
        if last:  # nothing more to show: clear the line before any result is printed
            self.close()

    def on_end(self, report: dict) -> None:
        """A job may end before the steps it announced (a fit's tempo ladder that ends
        early): its last step is then the last line of a log."""
        if self._log is not None and self._last is not None:
            self._log_line(self._last, ended=True)
        self.close()

    def close(self) -> None:
        self._log = None
        if self._bar is not None:
            self._bar.close()
            self._bar = None
