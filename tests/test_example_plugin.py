"""The example plugin package of docs/plugins.md (examples/inkmotion-example-plugin),
pip-installed by `make test` like any third-party package: listed, used by a fit and run as
a job kind; and a plugin with a wrong hook signature is refused naming it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("inkmotion_example", reason="examples/inkmotion-example-plugin is not "
                    "installed; run `make test` (it installs it)")


def inkmotion(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=600)


def test_the_plugins_are_listed_with_their_package() -> None:
    res = inkmotion("plugins", "--json")
    assert res.returncode == 0, res.stderr
    rows = {(p["kind"], p["name"]): p for p in json.loads(res.stdout)}
    assert ("image-loss", "edge") in rows and ("job-kind", "grid") in rows
    assert "inkmotion-example-plugin" in rows[("image-loss", "edge")]["origin"]
    assert rows[("image-loss", "edge")]["error"] is None


def test_a_fit_uses_the_example_loss(tmp_path: Path) -> None:
    out = tmp_path / "fit"
    # no tempo ladder: it may trade some of the image's fit for a more rapid motion
    res = inkmotion("run", "fit", "text:hi", "--loss", "mse", "--loss", "edge",
                    "--edge-scale", "2", "--steps", "30", "--size", "96", "--no-record",
                    "--rapid-within", "0", "--out", str(out))
    assert res.returncode == 0, res.stderr
    report = json.loads((out / "report.json").read_text())
    assert report["final_loss"]["edge"] < report["initial_loss"]["edge"]
    spec = json.loads((out / "job.json").read_text())["spec"]["params"]
    assert {"name": "edge", "scale": 2} in spec["losses"]


def test_the_example_job_kind_runs(tmp_path: Path) -> None:
    out = tmp_path / "grid"
    res = inkmotion("run", "grid", "hello", "--cells", "4", "--no-record", "--out", str(out))
    assert res.returncode == 0, res.stderr
    plan = json.loads((out / "plan.json").read_text())
    assert len(plan["paths"][0]["points"]) == 16
    assert json.loads((out / "report.json").read_text())["title"] == "hello"


def test_a_wrong_hook_signature_is_refused_naming_the_plugin() -> None:
    from inkmotion.errors import PluginError
    from inkmotion.plugin_host import PluginHost, hookimpl

    class Misspelt:
        @hookimpl
        def inkmotion_image_losses(self, size):  # the spec takes no argument
            return []

    with pytest.raises(PluginError) as info:
        PluginHost().register(Misspelt(), name="my-broken-loss")
    assert "my-broken-loss" in str(info.value)
