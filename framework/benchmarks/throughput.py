"""Throughput: default fits per minute on this machine, jobs side by side and in batches.

- ``concurrent_N_fits_per_min``: N ``inkmotion run fit`` processes started together, each
  with the default thread count (:mod:`inkmotion.devices`, the same count alone or beside
  others), N fits / the wall time until the last one finished.
- ``oversubscribed_2_fits_per_min``: the same for 2 processes that each take every core
  (``INKMOTION_THREADS`` = cores: no thread policy), the fight the policy avoids.
- ``batch_B_fits_per_min``: B fits as one batched optimisation in one process
  (:func:`inkmotion.jobs.shell.run_jobs_together`), B / its wall time (in this process,
  warmed up by a short fit: no process start-up, which the jobs side by side pay).
- ``pair_over_alone``: the wall time of two fits of the same word side by side over one
  fit of it alone (the goal is ≤ 1.3), the median over :data:`PAIR_REPEATS` rounds of
  (alone, pair), after a first fit that warms the page cache and is not counted: a
  machine whose speed drifts moves both figures of a round together. ``fit_alone_s``
  and ``fit_pair_s`` are the medians of the two walls.

The drawings are built-in words (text:WORD, a different one per fit), fitted with the fit
kind's defaults, so the figures need no data beside the repository.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

WORDS = ("hello", "world", "graffiti", "motion", "sigma", "lognormal", "robot", "drawing",
         "paint", "spray", "marker", "pencil", "brush", "stroke", "curve", "letter")


#: the word of the alone-and-pair rounds (the first of concurrency 1), and how many rounds
PAIR_WORD, PAIR_REPEATS = WORDS[0], 3


def _concurrent(n: int, root: Path, env: dict[str, str], device: str = "cpu",
                same: str | None = None) -> float:
    """Seconds until ``n`` fits started together all finished: of different words, or all
    of the word ``same``."""
    started = time.perf_counter()
    procs = [subprocess.Popen([sys.executable, "-m", "inkmotion", "run", "fit",
                               f"text:{same or WORDS[k % len(WORDS)]}", "--device", device,
                               "--out", str(root / f"c{n}-{k}")],
                              env={**os.environ, **env}, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
             for k in range(n)]
    codes = [p.wait() for p in procs]
    if any(codes):
        raise RuntimeError(f"a fit of the throughput benchmark failed (exit codes {codes})")
    return time.perf_counter() - started


def _batch(b: int, root: Path, device: str = "cpu") -> float:
    """Seconds of ``b`` fits as one batched optimisation in this process."""
    from inkmotion.jobs.shell import Together, run_jobs_together
    from inkmotion.jobs.spec import JobSpec

    jobs = [Together(JobSpec(kind="fit", inputs={"drawing": f"text:{WORDS[k % len(WORDS)]}"},
                             record_every=0, device=device), root / f"b{b}-{k}")
            for k in range(b)]
    started = time.perf_counter()
    outcomes = run_jobs_together(jobs)
    failed = [o for o in outcomes if isinstance(o, BaseException)]
    if failed:
        raise RuntimeError(f"a batched fit of the throughput benchmark failed: {failed[0]}")
    return time.perf_counter() - started


def _warm_up(folder: Path, device: str) -> None:
    """A 5-step fit here, so the first batch does not pay the fit's first imports."""
    from inkmotion.jobs.shell import run_job
    from inkmotion.jobs.spec import JobSpec

    run_job(JobSpec(kind="fit", inputs={"drawing": "text:warm"}, params={"steps": 5},
                    record_every=0, device=device), folder)


def _pair_rounds(root: Path, env: dict[str, str], device: str) -> dict[str, float]:
    """``pair_over_alone``, ``fit_alone_s`` and ``fit_pair_s`` (module docstring)."""
    _concurrent(1, root / "warm-cache", env, device, same=PAIR_WORD)
    alone, pair = [], []
    for r in range(PAIR_REPEATS):
        alone.append(_concurrent(1, root / f"alone{r}", env, device, same=PAIR_WORD))
        pair.append(_concurrent(2, root / f"pair{r}", env, device, same=PAIR_WORD))
    return {"pair_over_alone": statistics.median(p / a for p, a in zip(pair, alone,
                                                                         strict=True)),
            "fit_alone_s": statistics.median(alone), "fit_pair_s": statistics.median(pair)}


def bench_throughput(concurrency: tuple[int, ...] = (1, 2, 4),
                     batches: tuple[int, ...] = (1, 4, 16),
                     device: str = "cpu") -> dict[str, float]:
    """The figures of the module docstring (minutes of work: many full fits) on ``device``
    (on a GPU the jobs side by side share it)."""
    from inkmotion.devices import available_cores

    figures: dict[str, float] = {}
    cores = available_cores()
    free = {"INKMOTION_THREADS": "", "OMP_NUM_THREADS": ""}  # the default, not an override
    with tempfile.TemporaryDirectory(prefix="inkmotion-throughput-") as tmp:
        root = Path(tmp)
        figures.update(_pair_rounds(root, free, device))
        for n in concurrency:
            wall = (figures["fit_alone_s"] if n == 1  # the rounds' fits alone: the same
                    else _concurrent(n, root / f"n{n}", free, device))
            figures[f"concurrent_{n}_fits_per_min"] = 60.0 * n / wall
        if device == "cpu":
            wall = _concurrent(2, root / "over", {"INKMOTION_THREADS": str(cores)})
            figures["oversubscribed_2_fits_per_min"] = 120.0 / wall
        _warm_up(root / "warm", device)
        for b in batches:
            figures[f"batch_{b}_fits_per_min"] = 60.0 * b / _batch(b, root / f"batch{b}",
                                                                    device)
    return figures
