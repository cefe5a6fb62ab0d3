"""Gallery build time: 100 jobs from scratch, again unchanged, and after one job more.

The jobs are real: three are run here (a fit at the default settings but 200 steps, its
evaluation and its simulated drawing, each recorded), and a SQLite job store in a
temporary data directory receives 100 rows in the mix a user's store holds: 80 fits, 8
evaluations and 8 simulations that succeeded (each with its own copy of the artifacts in
the data directory's layout, so every page links and thumbnails its own files), 2 failed
and 2 running. Each build is the command a user runs, ``inkmotion gallery build --out
SITE``, in a new process (its start-up, the plugins' loading and the store's query
included).

The site's own size counts the files it adds; the artifacts it hard-links (its downloads
and full-size figures) take no space twice.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from inkmotion.jobs.shell import run_job
from inkmotion.jobs.spec import JobSpec

MIX = (("fit", 80), ("evaluate", 8), ("simulate", 8), ("failed", 2), ("running", 2))


def _make_results(root: Path) -> dict[str, Path]:
    fit = root / "fit"
    run_job(JobSpec(kind="fit", inputs={"drawing": "text:gallery"}, params={"steps": 200},
                    device="cpu"), fit, record=True)
    plan = str(fit / "plan.json")
    out = {"fit": fit}
    for kind in ("evaluate", "simulate"):
        run_job(JobSpec(kind=kind, inputs={"plan": plan}, device="cpu"), root / kind,
                record=True)
        out[kind] = root / kind
    return out


def _add_job(url: str, data: Path, kind: str, results: dict[str, Path], n: int) -> None:
    import json

    from inkmotion import store

    source = results.get(kind, results["fit"])
    spec = json.loads((source / "job.json").read_text())["spec"]
    real_kind = kind if kind in results else "fit"
    label = f"text:word{n}" if real_kind == "fit" else spec["inputs"]["plan"]
    spec["inputs"] = {"drawing": label} if real_kind == "fit" else spec["inputs"]
    r = store.create_job(spec, kind=real_kind, queue="optimise", label=label,
                         total=200, db_url=url)
    store.mark_running(r.id, "bench@local", db_url=url, owner="b", lease_s=3600)
    if kind == "running":
        store.update_progress(r.id, 40 + n % 100, 200, db_url=url, owner="b", lease_s=3600)
    elif kind == "failed":
        store.mark_failed(r.id, "Input text:?: no glyphs to draw; give a word.", db_url=url)
    else:
        artifacts = data / "jobs" / r.id / "artifacts"
        shutil.copytree(source, artifacts)
        report = json.loads((artifacts / "report.json").read_text())
        store.mark_succeeded(r.id, str(artifacts), db_url=url, owner="b",
                             metrics=report.get("metrics"))


def bench_gallery(jobs: int = 100) -> dict:
    """Seconds to build the gallery of ``jobs`` jobs, to rebuild it unchanged, and to
    rebuild it after one more job; the site's size."""
    from inkmotion import store

    with tempfile.TemporaryDirectory(prefix="inkmotion-bench-gallery-") as tmp:
        root = Path(tmp)
        results = _make_results(root / "results")
        url, data = f"sqlite:///{root / 'jobs.sqlite3'}", root / "data"
        mix = [k for k, count in MIX for _ in range(count)]  # 100 jobs; others: resampled
        kinds = [mix[i * len(mix) // jobs] for i in range(jobs)]
        for n, kind in enumerate(kinds):
            _add_job(url, data, kind, results, n)
        site = root / "site"

        env = {**os.environ, "INKMOTION_DB_URL": url, "INKMOTION_DATA_DIR": str(data)}

        def timed_build() -> tuple[float, str]:
            t0 = time.perf_counter()
            res = subprocess.run([sys.executable, "-m", "inkmotion", "gallery", "build",
                                  "--out", str(site)], env=env, capture_output=True, text=True)
            seconds = time.perf_counter() - t0
            if res.returncode != 0:
                raise RuntimeError(f"inkmotion gallery build failed: {res.stderr.strip()}")
            return seconds, res.stdout.splitlines()[0]

        first_s, _ = timed_build()
        same_s, same = timed_build()
        _add_job(url, data, "fit", results, len(kinds))
        one_s, one = timed_build()
        own = sum(p.stat().st_size for p in site.rglob("*")
                  if p.is_file() and p.stat().st_nlink == 1)
        store.dispose_engines()
    return {"gallery_jobs": len(kinds), "gallery_build_s": round(first_s, 2),
            "gallery_rebuild_unchanged_s": round(same_s, 2),
            "gallery_rebuild_one_more_s": round(one_s, 2),
            "gallery_rebuild_unchanged": same.removeprefix("gallery: "),
            "gallery_rebuild_one_more": one.removeprefix("gallery: "),
            "gallery_site_own_mb": round(own / 1e6, 2)}
