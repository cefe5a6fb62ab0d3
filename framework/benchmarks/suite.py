"""``inkmotion bench``: run the benchmarks and print their figures, each with its unit,
its target in words (met, or missed by how much) and a legend that says what it is
(:mod:`inkmotion.benchmarks.figures`)."""

from __future__ import annotations

from collections.abc import Callable

import torch
from rich.console import Console
from rich.table import Table

from inkmotion.benchmarks.figures import TARGETS, describe, show_value, verdict

__all__ = ["DEFAULT_BENCHES", "TARGETS", "figures_record", "print_figures", "run_benchmarks"]

#: run when no ``--only`` is given; the others run only when named (queue: it starts
#: redis-server and worker subprocesses, a few minutes; generation: CLIP ViT-B-32 jobs)
DEFAULT_BENCHES = ("kinematics", "raster", "spray", "fit", "extraction", "recording")


def _benches(fit_input: str | None, device: str, repeat: int = 1
             ) -> dict[str, Callable[[], dict]]:
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

        figures = bench_fit(fit_input, device=device, warm=True, repeat=repeat)
        if device != "cpu":  # the GPU figure: the same tag at 1000 px
            figures.update(bench_fit(fit_input, size=1000, device=device))
        return figures

    def extraction() -> dict:
        from inkmotion.benchmarks.extraction import bench_extraction

        return bench_extraction()

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

    def studio() -> dict:
        from inkmotion.benchmarks.studio import bench_studio

        return bench_studio()

    def throughput() -> dict:
        from inkmotion.benchmarks.throughput import bench_throughput

        return bench_throughput(device=device)

    def tsp() -> dict:
        from inkmotion.benchmarks.tsp import bench_tsp, format_table

        figures = bench_tsp()
        print(format_table(figures))
        return {}

    return {"kinematics": kinematics, "raster": raster, "spray": spray, "fit": fit,
            "extraction": extraction, "recording": recording,
            "queue": queue, "generation": generation, "gallery": gallery, "tsp": tsp,
            "throughput": throughput, "studio": studio}


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
                   device: str = "cpu", show: bool = True, repeat: int = 1) -> dict:
    """Run the chosen benchmarks (:data:`DEFAULT_BENCHES` by default) on ``device`` with
    ``threads`` torch threads, the fit's warm run ``repeat`` times; print them
    (:func:`print_figures`, unless not ``show``) and return them."""
    import os

    from inkmotion.devices import resolve_device

    console = console or Console()
    device = str(resolve_device(device))
    benches = _benches(fit_input, device, repeat)
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
    if show:
        print_figures(figures, console, f"inkmotion bench ({device}, {threads} CPU threads)")
    return figures


def figures_record(figures: dict) -> dict[str, dict]:
    """The figures as ``bench --json`` prints them: for each, its value, unit, what it
    measures and, where it has one, its target (``bound``, ``cmp``) and whether it was
    ``met`` (a figure that is not a finite number is not), as the table says in words."""
    record = {}
    for key, value in figures.items():
        unit, what = describe(key)
        entry: dict = {"value": value, "unit": unit, "what": what}
        target = TARGETS.get(key)
        if target is not None:
            met, words = verdict(value, *target, unit)
            entry.update(bound=target[0], cmp=target[1], met=met, verdict=words)
        record[key] = entry
    return record


def print_figures(figures: dict, console: Console, title: str) -> None:
    """The table (figure, value with its unit, target and whether it was met, in words and
    in colour), then what each figure is, one line each: :func:`figures_record` shown."""
    record = figures_record(figures)
    table = Table("figure", "value", "target", title=title)
    for key, entry in record.items():
        words = (f"[{'green' if entry['met'] else 'red'}]{entry['verdict']}[/]"
                 if "verdict" in entry else "")
        table.add_row(key, show_value(entry["value"], entry["unit"]), words)
    console.print(table)
    if record:
        console.print("What the figures are:", highlight=False)
        grid = Table.grid(padding=(0, 1))
        grid.add_column(no_wrap=True, style="bold")
        grid.add_column()
        for key, entry in record.items():
            grid.add_row(f"  {key}", entry["what"])
        console.print(grid, highlight=False)
