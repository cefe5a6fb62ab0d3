"""Real jobs for the gallery's tests: results folders made by the job shell (a fit with a
spray preview, its evaluation and its simulated drawing) and a SQLite job store whose rows
are in every status, the succeeded ones pointing at artifact folders in a data directory.

Included from ``tests/conftest.py`` (``pytest_plugins``); session-scoped, so the jobs run
once for every gallery test.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from inkmotion import store
from inkmotion.jobs.shell import run_job
from inkmotion.jobs.spec import JobSpec

TINY = {"steps": 8, "size": 64}


@dataclass
class GalleryJobs:
    """What the fixture made: results folders and a job store."""

    results: Path  # holds fit-hi/, fit-hi-eval/, fit-hi-robot/
    db_url: str
    data_dir: Path
    ids: dict[str, str]  # "succeeded", "running", "failed", "queued", "missing" -> job id

    @property
    def fit(self) -> Path:
        return self.results / "fit-hi"


def _run(kind: str, inputs: dict[str, str], params: dict, out: Path) -> None:
    run_job(JobSpec(kind=kind, inputs=inputs, params=params, device="cpu"), out, record=True)


def make_results(root: Path) -> Path:
    """Run the three jobs in-process into ``root`` (about 15 s on 2 cores)."""
    _run("fit", {"drawing": "text:hi"}, {**TINY, "spray_preview": True}, root / "fit-hi")
    plan = str(root / "fit-hi" / "plan.json")
    _run("evaluate", {"plan": plan}, {}, root / "fit-hi-eval")
    _run("simulate", {"plan": plan}, {}, root / "fit-hi-robot")
    return root


def make_store(root: Path, fit: Path) -> tuple[str, Path, dict[str, str]]:
    """A SQLite store in ``root`` with a job in each status (the succeeded one's artifacts
    are a copy of ``fit`` in the data directory's layout)."""
    data = root / "data"
    url = f"sqlite:///{root / 'jobs.sqlite3'}"
    spec = JobSpec(kind="fit", inputs={"drawing": "text:hi"}, params=dict(TINY)).to_dict()
    ids: dict[str, str] = {}
    metrics = json.loads((fit / "report.json").read_text())["metrics"]
    for status in ("succeeded", "running", "failed", "queued", "missing"):
        label = {"succeeded": "text:hi", "running": "text:running word",
                 "failed": "text:broken", "queued": "text:waiting",
                 "missing": "text:gone"}[status]
        r = store.create_job({**spec, "inputs": {"drawing": label}}, kind="fit",
                             queue="optimise", label=label, total=8, db_url=url)
        ids[status] = r.id
        if status == "queued":
            continue
        store.mark_running(r.id, "w1@test", db_url=url, owner="a1", lease_s=3600)
        if status == "running":
            store.update_progress(r.id, 3, 8, db_url=url, owner="a1", lease_s=3600)
        elif status == "failed":
            store.mark_failed(r.id, "Input text:broken: no glyphs to draw; give a word.",
                              db_url=url)
        else:
            artifacts = data / "jobs" / r.id / "artifacts"
            if status == "succeeded":
                shutil.copytree(fit, artifacts)
            store.mark_succeeded(r.id, str(artifacts), db_url=url, owner="a1",
                                 metrics=metrics)
    return url, data, ids


@pytest.fixture(scope="session")
def gallery_jobs(tmp_path_factory: pytest.TempPathFactory) -> Iterator[GalleryJobs]:
    root = tmp_path_factory.mktemp("gallery-jobs")
    results = make_results(root / "results")
    url, data, ids = make_store(root, results / "fit-hi")
    yield GalleryJobs(results, url, data, ids)
    store.dispose_engines()
