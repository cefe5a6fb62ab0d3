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
    "spray_host_syncs": (0, "≤"),
    "speedup": (3.0, "≥"),
    "fit_wall_s": (30.0, "≤"),
    "recording_ratio": (1.1, "≤"),
    "tag_300_steps_s": (30.0, "≤"),  # the goal on a CUDA GPU
    "queue_lost": (0, "≤"),
    "pair_over_alone": (1.3, "≤"),
    "queue_completed_twice": (0, "≤"),
}

#: run when no ``--only`` is given; the others run only when named (queue: it starts
#: redis-server and worker subprocesses, a few minutes; generation: CLIP ViT-B-32 jobs)
DEFAULT_BENCHES = ("kinematics", "raster", "spray", "fit", "recording")


def _benches(fit_input: str | None, device: str) -> dict[str, Callable[[], dict]]:
    def kinematics() -> dict:
        from inkmotion.benchmarks.kinematics import bench_kinematics

        return _on(bench_kinematics, device)

    def raster() -> dict:
        from inkmotion.benchmarks.raster import bench_raster

        return _on(bench_raster, device)

    def spray() -> dict:
        from inkmotion.benchmarks.spray import bench_spray

        return _on(bench_spray, device)

    def fit() -> dict:
        from inkmotion.benchmarks.fit import bench_fit

        figures = bench_fit(fit_input, device=device)
        if device != "cpu":  # the GPU figure: the same tag at 1000 px
            figures.update(bench_fit(fit_input, size=1000, device=device))
        return figures

    def recording() -> dict:
        from inkmotion.benchmarks.recording import bench_recording

        return bench_recording()

    def queue() -> dict:
        from inkmotion.benchmarks.queue import bench_queue

        return bench_queue()

    def generation() -> dict:
        from inkmotion.benchmarks.generation import bench_generation

        return bench_generation(device=device)

    def gallery() -> dict:
        from inkmotion.benchmarks.gallery import bench_gallery

        return bench_gallery()

    def throughput() -> dict:
        from inkmotion.benchmarks.throughput import bench_throughput

        return bench_throughput(device=device)

    def tsp() -> dict:
        from inkmotion.benchmarks.tsp import bench_tsp, format_table

        figures = bench_tsp()
        print(format_table(figures))
        return {}

    return {"kinematics": kinematics, "raster": raster, "spray": spray, "fit": fit,
            "recording": recording,
            "queue": queue, "generation": generation, "gallery": gallery, "tsp": tsp,
            "throughput": throughput}


def _on(bench: Callable[..., dict], device: str) -> dict:
    """Run ``bench`` on ``device`` (benchmarks that predate the argument run on the CPU)."""
    import inspect

    if "device" in inspect.signature(bench).parameters:
        return bench(device=device)
    if device != "cpu":
        return {}
    return bench()


def run_benchmarks(only: list[str] | None = None, fit_input: str | None = None,
                   threads: int = 2, console: Console | None = None,
                   device: str = "cpu") -> dict:
    """Run the chosen benchmarks (:data:`DEFAULT_BENCHES` by default) on ``device`` with
    ``threads`` torch threads; print a table of figure, value and target; return them."""
    import os

    from inkmotion.devices import resolve_device

    console = console or Console()
    device = str(resolve_device(device))
    benches = _benches(fit_input, device)
    unknown = set(only or []) - set(benches)
    if unknown:
        from inkmotion.errors import InkmotionError

        raise InkmotionError(f"Unknown benchmark(s) {', '.join(sorted(unknown))}; "
                             f"choose from {', '.join(benches)}.")
    previous = torch.get_num_threads()
    previous_env = os.environ.get("INKMOTION_THREADS")
    os.environ["INKMOTION_THREADS"] = str(threads)  # jobs run by the benchmarks use it too
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
        if previous_env is None:
            os.environ.pop("INKMOTION_THREADS", None)
        else:
            os.environ["INKMOTION_THREADS"] = previous_env
    table = Table("figure", "value", "target",
                  title=f"inkmotion bench ({device}, {threads} CPU threads)")
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
