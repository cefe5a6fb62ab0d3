"""Benchmark of the 'spray' renderer: the differentiable expected density against 'raster'
on the same scene, forward + backward (the raster benchmark's scribble: 750 cubic
segments, 350×350, width 3 px), host synchronisations of a fit's spray session, and the
seeded preview of a word's plan at 350 and 4000 px."""

from __future__ import annotations

import time

import torch

from inkmotion.benchmarks.raster import (
    SEGMENTS,
    STROKE_WIDTH,
    _time_forward_backward,
    raster_host_syncs,
    scribble_segments,
)
from inkmotion.rendering.raster import RasterSession
from inkmotion.rendering.spray import SpraySession


def _word_drawing() -> object:
    """The plan the dce initialiser makes of text:inkmotion at 350 px (no fit needed)."""
    import inkmotion
    from inkmotion.kinds.read import read_input
    from inkmotion.plugin_host.protocols import JobInputs
    from inkmotion.sigma_lognormal import Drawing

    traces = read_input("text:inkmotion").fit_to_canvas(350)
    canvas = (int(traces.width), int(traces.height))
    plans = inkmotion.plugin("initialiser", "dce")(JobInputs(canvas, traces=traces),
                                                   dtype=torch.float64)
    return Drawing((float(canvas[0]), float(canvas[1])), plans)


def bench_spray(repeats: int = 10, device: torch.device | str = "cpu") -> dict[str, float]:
    """{"spray_ms", "spray_raster_ms", "spray_vs_raster", "spray_host_syncs",
    "spray_preview_350_s", "spray_preview_4000_s"} (previews on the CPU only)."""
    from inkmotion.rendering.spray_preview import spray_preview

    device = torch.device(device)
    seg = scribble_segments().to(device)
    widths = torch.full((SEGMENTS,), STROKE_WIDTH, device=device)
    spray_ms = _time_forward_backward(SpraySession(), seg, widths, repeats)
    raster_ms = _time_forward_backward(RasterSession(static=device.type != "cpu"), seg,
                                       widths, repeats)
    figures = {"spray_ms": spray_ms, "spray_raster_ms": raster_ms,
               "spray_vs_raster": spray_ms / raster_ms,
               "spray_host_syncs": raster_host_syncs(SpraySession(), seg, widths)}
    if device.type == "cpu":
        drawing = _word_drawing()
        for size in (350, 4000):
            t0 = time.perf_counter()
            spray_preview(drawing, size, seed=0)
            figures[f"spray_preview_{size}_s"] = time.perf_counter() - t0
    return figures


if __name__ == "__main__":
    print(bench_spray())
