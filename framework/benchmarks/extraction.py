"""Benchmark of tracing a picture (:mod:`inkmotion.tracing`): a recorded tag rendered as a
1000 × 1000 scan (8 px ink, blur, grain, light falling off, JPEG 70: the picture
benchmark's 'scan' setting), decoded and traced. The first trace of a process includes
the first imports and calls of the libraries it uses (scikit-image's skeleton and pixel
graph, OpenCV, shapely); the figure with the target is the median of the next ones."""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path


def bench_extraction(source: str = "sample:tempt-1", repeats: int = 5) -> dict[str, float]:
    """{"extraction_first_s", "extraction_s", "extraction_decode_s", "extraction_strokes"}."""
    from dataclasses import replace

    from inkmotion.benchmarks.pictures import SCANS, render_scan
    from inkmotion.kinds.read import read_input
    from inkmotion.tracing import read_picture, trace_picture

    scan = replace(SCANS[1], size=1000)
    truth = read_input(source).fit_to_canvas(scan.size).strokes
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scan.jpg"
        render_scan(truth, scan, path)
        times, decode = [], []
        for _ in range(repeats + 1):
            start = time.perf_counter()
            picture = read_picture(str(path))
            mid = time.perf_counter()
            traces = trace_picture(picture)
            times.append(time.perf_counter() - start)
            decode.append(mid - start)
    return {"extraction_first_s": times[0], "extraction_s": statistics.median(times[1:]),
            "extraction_decode_s": statistics.median(decode[1:]),
            "extraction_strokes": float(len(traces.strokes))}
