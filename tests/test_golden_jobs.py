"""Golden job files of spec version 4, one per built-in kind, written before the job kinds
moved to ``inkmotion.kinds`` (issue 21): each still reproduces its results on the CPU —
the plans of fit, tag and abstract bit for bit, the simulated arm's joint, Cartesian and
executed trajectories byte for byte, the evaluation's table exactly — and every figure of
its report.json but the wall-clock ones is unchanged.

The files are as ``inkmotion run`` wrote them: inputs relative to tests/data/v4_jobs, the
tiny CLIP config relative to the repository, random weights as recorded, the abstraction's
tour by elkai (deterministic, where fast-tsp's time budget is not). The results depend on
the thread count in the last bits, so they hold for the 2 torch threads of the machines
that wrote them (``INKMOTION_THREADS=2``, set here)."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "v4_jobs"
#: report keys that measure this machine's clock or set-up, not the result
CLOCK = {"wall_s", "fit_s", "s_per_step", "solve_s", "timing_s", "joints_s", "planning_s",
         "wall_time_s", "wall_s_per_sim_s",
         "real_time_factor", "threads", "device", "checkpoints"}


def figures(value: object) -> object:
    """``value`` (a report) without its clock readings, at any depth."""
    if isinstance(value, dict):
        return {k: figures(v) for k, v in value.items() if k not in CLOCK}
    if isinstance(value, list):
        return [figures(v) for v in value]
    return value


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def rerun(tmp_path_factory) -> Path:
    """Every golden job.json run again with ``inkmotion run --config``, in kind order (the
    simulate and evaluate jobs read the golden fit's plan)."""
    work = tmp_path_factory.mktemp("golden")
    shutil.copy(GOLDEN / "photo.png", work / "photo.png")
    (work / "fit").mkdir()
    shutil.copy(GOLDEN / "fit" / "plan.json", work / "fit" / "plan.json")
    env = {**os.environ, "INKMOTION_THREADS": "2", "PYTHONWARNINGS": "ignore"}
    for kind in ("fit", "tag", "abstract", "simulate", "evaluate"):
        job = json.loads((GOLDEN / kind / "job.json").read_text())
        params = job["spec"]["params"]
        if "clip_model" in params:
            params["clip_model"] = str(ROOT / params["clip_model"])
        config = work / f"{kind}.json"
        config.write_text(json.dumps(job))
        res = subprocess.run([sys.executable, "-m", "inkmotion", "run", "--config", str(config),
                              "--no-record", "--out", str(work / "new" / kind)], cwd=work,
                             capture_output=True, text=True, timeout=600, env=env)
        assert res.returncode == 0, f"{kind}: {res.stderr}"
    return work / "new"


@pytest.mark.parametrize("kind", ["fit", "tag", "abstract"])
def test_a_golden_job_reproduces_its_plan_bit_for_bit(rerun: Path, kind: str) -> None:
    assert (rerun / kind / "plan.json").read_bytes() == (GOLDEN / kind / "plan.json").read_bytes()


@pytest.mark.parametrize("kind", ["fit", "tag", "abstract", "simulate", "evaluate"])
def test_a_golden_job_reports_the_same_figures(rerun: Path, kind: str) -> None:
    old = json.loads((GOLDEN / kind / "report.json").read_text())
    new = json.loads((rerun / kind / "report.json").read_text())
    assert figures(new) == figures(old)


def test_the_golden_simulation_moves_the_arm_the_same_way(rerun: Path) -> None:
    digests = json.loads((GOLDEN / "simulate" / "sha256.json").read_text())
    for name, digest in digests.items():
        assert sha256(rerun / "simulate" / name) == digest, name


def test_the_golden_evaluation_gives_the_same_table(rerun: Path) -> None:
    assert ((rerun / "evaluate" / "evaluation.json").read_bytes()
            == (GOLDEN / "evaluate" / "evaluation.json").read_bytes())
