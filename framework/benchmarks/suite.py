"""``inkmotion bench``: run the benchmarks and print their figures with the targets."""

from __future__ import annotations

import math
from collections.abc import Callable

import torch
from rich.console import Console
from rich.table import Table

#: figure -> (target, comparison) for the issue's acceptance targets
TARGETS: dict[str, tuple[float, str]] = {
    "kinematics_m150_ms": (10.0, "≤"),
    "kinematics_ratio_2000_500": (6.0, "≤"),
    "raster_ms": (60.0, "≤"),
    "speedup": (3.0, "≥"),
    "fit_wall_s": (30.0, "≤"),
    "recording_ratio": (1.1, "≤"),
    "queue_lost": (0, "≤"),
    "queue_completed_twice": (0, "≤"),
}

#: run when no ``--only`` is given; the others (queue: it starts redis-server and worker
#: subprocesses, a few minutes) run only when named
DEFAULT_BENCHES = ("kinematics", "raster", "fit", "recording")


def _benches(fit_input: str | None) -> dict[str, Callable[[], dict]]:
    def kinematics() -> dict:
        from inkmotion.benchmarks.kinematics import bench_kinematics

        return bench_kinematics()

    def raster() -> dict:
        from inkmotion.benchmarks.raster import bench_raster

        return bench_raster()

    def fit() -> dict:
        from inkmotion.benchmarks.fit import bench_fit

        return bench_fit(fit_input)

    def recording() -> dict:
        from inkmotion.benchmarks.recording import bench_recording

        return bench_recording()

    def queue() -> dict:
        from inkmotion.benchmarks.queue import bench_queue

        return bench_queue()

    return {"kinematics": kinematics, "raster": raster, "fit": fit, "recording": recording,
            "queue": queue}


def run_benchmarks(only: list[str] | None = None, fit_input: str | None = None,
                   threads: int = 2, console: Console | None = None) -> dict:
    """Run the chosen benchmarks (:data:`DEFAULT_BENCHES` by default) with ``threads``
    torch threads; print a table of figure, value and target; return the figures."""
    console = console or Console()
    benches = _benches(fit_input)
    unknown = set(only or []) - set(benches)
    if unknown:
        from inkmotion.errors import InkmotionError

        raise InkmotionError(f"Unknown benchmark(s) {', '.join(sorted(unknown))}; "
                             f"choose from {', '.join(benches)}.")
    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    figures: dict = {}
    try:
        for name, fn in benches.items():
            if name not in (only or DEFAULT_BENCHES):
                continue
            with console.status(f"benchmark {name} …"):
                figures.update(fn())
    finally:
        torch.set_num_threads(previous)
    table = Table("figure", "value", "target", title=f"inkmotion bench ({threads} threads)")
    for key, value in figures.items():
        target = TARGETS.get(key)
        shown = f"{value:.3f}" if isinstance(value, float) and math.isfinite(value) else str(value)
        if target is None:
            table.add_row(key, shown, "")
            continue
        bound, cmp = target
        ok = value <= bound if cmp == "≤" else value >= bound
        table.add_row(key, shown, f"[{'green' if ok else 'red'}]{cmp} {bound}[/]")
    console.print(table)
    return figures
