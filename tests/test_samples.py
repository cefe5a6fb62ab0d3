"""The samples that ship with inkmotion: listed, read as ``sample:NAME`` by every reader and
job kind, refused by name when unknown, installed with the package (a built wheel holds
them and their notice), and the tags byte for byte the recorded files they claim to be."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from inkmotion.errors import InputError
from inkmotion.kinds.read import read_input
from inkmotion.samples import SAMPLES, Sample, find, locate, path_of

ROOT = Path(__file__).resolve().parents[1]
SHARED_GML = ROOT.parent / "shared" / "data" / "gml"


def inkmotion(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=300, cwd=cwd, env=env)


def test_samples_lists_every_sample_with_its_file() -> None:
    res = inkmotion("samples", "--json")
    assert res.returncode == 0, res.stderr
    listed = json.loads(res.stdout)
    assert [s["source"] for s in listed] == [f"sample:{s.name}" for s in SAMPLES]
    for entry in listed:
        assert entry["path"] and Path(entry["path"]).is_file(), entry
        assert entry["licence"].startswith("MIT")
    table = inkmotion("samples")
    assert table.returncode == 0 and all(f"sample:{s.name}" in table.stdout for s in SAMPLES)
    path = inkmotion("samples", "--path", "tempt-2")
    assert path.returncode == 0 and path.stdout.strip() == path_of("tempt-2")


@pytest.mark.parametrize("sample", [s for s in SAMPLES if "fit" in s.kinds],
                         ids=lambda s: s.name)
def test_every_drawing_sample_reads_as_traces(sample: Sample) -> None:
    traces = read_input(f"sample:{sample.name}")
    assert traces.strokes and all(len(stroke) >= 2 for stroke in traces.strokes)
    if sample.input.startswith("tag"):  # recorded: time-stamped (evaluate --recording)
        assert len(traces.meta["t"]) == len(traces.strokes)


def test_an_unknown_sample_is_one_sentence_naming_the_samples(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"^sample:nope: no such sample; the samples are "):
        find("nope")
    assert locate("text:hello") == "text:hello" and locate("a/b.gml") == "a/b.gml"
    res = inkmotion("run", "fit", "sample:nope", "--out", str(tmp_path / "out"))
    assert res.returncode != 0
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: sample:nope: no such sample;")
    assert "tempt-1" in lines[0] and not (tmp_path / "out").exists()
    res = inkmotion("samples", "--path", "nope")
    assert res.returncode == 1 and res.stderr.startswith("error: sample:nope: no such sample")


def test_a_job_keeps_the_sample_name(tmp_path: Path) -> None:
    """job.json says ``sample:NAME``, not this installation's path: it reproduces anywhere."""
    out = tmp_path / "fit"
    res = inkmotion("run", "fit", "sample:tempt-2", "--steps", "3", "--size", "96",
                    "--no-record", "--out", str(out))
    assert res.returncode == 0, res.stderr
    spec = json.loads((out / "job.json").read_text())["spec"]
    assert spec["inputs"]["drawing"] == "sample:tempt-2"
    assert json.loads((out / "plan.json").read_text())["paths"]


def test_a_built_wheel_holds_the_samples_and_their_notice(tmp_path: Path) -> None:
    res = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                          "--no-build-isolation", "-q", "-w", str(tmp_path), str(ROOT)],
                         capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert res.returncode == 0, res.stderr
    (wheel,) = tmp_path.glob("inkmotion-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for sample in SAMPLES:
        assert f"inkmotion/samples/{sample.file}" in names
    assert "inkmotion/samples/NOTICE.md" in names
    assert any(n.startswith("inkmotion/gallery_assets/templates/") for n in names)
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)


@pytest.mark.skipif(not SHARED_GML.is_dir(), reason="../shared/data/gml is absent")
def test_the_shipped_tags_are_the_recorded_files() -> None:
    for sample in SAMPLES:
        if sample.file.endswith(".gml"):
            original = SHARED_GML / sample.file
            assert Path(path_of(sample.name)).read_bytes() == original.read_bytes()
