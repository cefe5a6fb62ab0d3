"""End-to-end: ``inkmotion evaluate`` on a fitted word: the table, the files, the ratios."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path


def inkmotion(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=300, env=env)


def test_evaluate_writes_the_table_and_plots(tmp_path: Path) -> None:
    fit = tmp_path / "fit"
    res = inkmotion("run", "fit", "text:hi", "--out", str(fit), "--steps", "40", "--size",
                    "150", "--no-record")
    assert res.returncode == 0, res.stderr
    out = tmp_path / "eval"
    res = inkmotion("evaluate", str(fit / "plan.json"), "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert {"evaluation.json", "evaluation.csv", "speeds.png", "minima.png"} <= {
        p.name for p in out.iterdir()}
    doc = json.loads((out / "evaluation.json").read_text())
    methods = doc["methods"]
    assert set(methods) == {"sigma-lognormal", "minimum-jerk", "time-optimal"}
    assert all(m["ldj"] < 0 and m["msj"] > 0 for m in methods.values())
    assert methods["time-optimal"]["duration"] < methods["sigma-lognormal"]["duration"]
    assert doc["ratios"]["time-optimal"]["duration"] < 1
    assert "time-optimal/ΣΛ" in res.stderr  # the table on the terminal
