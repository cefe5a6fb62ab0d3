"""The terminal progress bar of ``inkmotion run``, an observer like the others.

The bar advances every step; the loss terms and T_end shown beside it are read from the
device only every ``refresh_s`` seconds, so the bar costs no GPU synchronisation on most
steps. Written to stderr, so stdout stays clean for scripts.
"""

from __future__ import annotations

import time
from typing import Any

from inkmotion.events import RunContext, StepState, scalars


class ProgressBar:
    """A tqdm bar over the job's steps, showing the loss terms and T_end."""

    def __init__(self, desc: str = "", refresh_s: float = 0.5) -> None:
        self.desc = desc
        self.refresh_s = refresh_s
        self._bar: Any = None
        self._shown = 0.0

    def on_start(self, ctx: RunContext) -> None:
        from tqdm.auto import tqdm

        self._bar = tqdm(total=ctx.total_steps, desc=self.desc or ctx.spec.kind, unit="step",
                         dynamic_ncols=True, leave=False)

    def on_step(self, state: StepState) -> None:
        if self._bar is None:
            return
        if state.total and state.total != self._bar.total:  # a kind that counts as it goes
            self._bar.total = state.total
        now = time.monotonic()
        if now - self._shown >= self.refresh_s or state.step == state.total:
            self._shown = now
            values = scalars({**state.losses, "T_end": state.t_end})
            shown = {k: f"{v:.4g}" for k, v in values.items() if k not in ("total", "T_end")}
            shown["T_end"] = f"{values['T_end']:.3g}"
            self._bar.set_postfix(shown, refresh=False)
        self._bar.update(1)

    def on_end(self, report: dict) -> None:
        self.close()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
