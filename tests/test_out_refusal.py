"""``--out`` onto results a user has: refused in one sentence unless ``--force``
(:func:`inkmotion.outputs.refuse_to_overwrite`, the one check every command calls)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from inkmotion.outputs import OutputExistsError, refuse_to_overwrite

TINY = ["--steps", "3", "--size", "64", "--no-record"]


def inkmotion(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=300, env=env)


def snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    """Every file under ``folder`` and the folder's siblings: content and mtime (ns)."""
    return {str(p.relative_to(folder.parent)): (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted(folder.parent.rglob("*")) if p.is_file()}


@pytest.fixture
def results(tmp_path: Path) -> Path:
    """A folder that holds what a run leaves (and one file of the user's)."""
    folder = tmp_path / "results" / "tag"
    folder.mkdir(parents=True)
    (folder / "plan.json").write_text('{"mine": true}')
    (folder / "report.json").write_text("{}")
    (folder / "notes.txt").write_text("keep me")
    return folder


def test_a_folder_with_results_is_refused_in_one_sentence(results: Path) -> None:
    with pytest.raises(OutputExistsError) as caught:
        refuse_to_overwrite(results, force=False)
    assert str(caught.value) == (
        f"{results} already holds results (report.json, plan.json, ...); pass --force to "
        "replace them, or choose another --out.")
    refuse_to_overwrite(results, force=True)


def test_a_missing_or_empty_folder_is_fine(tmp_path: Path) -> None:
    refuse_to_overwrite(tmp_path / "new", force=False)
    refuse_to_overwrite(tmp_path, force=False)
    (tmp_path / ".hidden").write_text("")
    with pytest.raises(OutputExistsError, match=r"holds results \(\.hidden\); pass --force"):
        refuse_to_overwrite(tmp_path, force=False)


def test_a_file_is_never_taken_for_a_folder_nor_the_reverse(tmp_path: Path) -> None:
    file = tmp_path / "x.png"
    file.write_bytes(b"png")
    for force in (False, True):
        with pytest.raises(OutputExistsError, match="is a file, not a folder"):
            refuse_to_overwrite(file, force)
        with pytest.raises(OutputExistsError, match="is a folder; give a file name"):
            refuse_to_overwrite(tmp_path, force, folder=False)
    with pytest.raises(OutputExistsError, match=r"x.png already exists; pass --force"):
        refuse_to_overwrite(file, False, folder=False)
    refuse_to_overwrite(file, True, folder=False)
    refuse_to_overwrite(tmp_path / "new.png", False, folder=False)


@pytest.mark.parametrize("command", [
    ["run", "fit", "text:hi", *TINY],
    ["run", "--config", "{config}", *TINY],
    ["evaluate", "{plan}"],
])
def test_commands_refuse_before_touching_anything(results: Path, tmp_path: Path,
                                                  command: list[str]) -> None:
    config = tmp_path / "job.json"
    config.write_text(json.dumps({"version": 4, "kind": "fit", "inputs": {"drawing": "text:hi"},
                                  "params": {}}))
    args = [a.format(config=config, plan=results / "plan.json") for a in command]
    before = snapshot(results)
    res = inkmotion(*args, "--out", str(results))
    assert res.returncode == 1
    assert res.stderr.strip() == (
        f"error: {results} already holds results (report.json, plan.json, ...); pass --force "
        "to replace them, or choose another --out.")
    assert snapshot(results) == before  # nothing written, nothing left beside it


def test_render_refuses_an_existing_image(tmp_path: Path) -> None:
    image = tmp_path / "tag.png"
    image.write_bytes(b"not yet a png")
    res = inkmotion("render", str(tmp_path / "plan.json"), "--out", str(image))
    assert res.returncode == 1 and image.read_bytes() == b"not yet a png"
    assert res.stderr.strip() == (f"error: {image} already exists; pass --force to replace "
                                  "it, or choose another --out.")


def test_an_empty_folder_is_used_and_force_replaces_results(tmp_path: Path) -> None:
    out = tmp_path / "hi"
    out.mkdir()
    first = inkmotion("run", "fit", "text:hi", "--out", str(out), *TINY)
    assert first.returncode == 0, first.stderr
    (out / "stale.txt").write_text("from before")
    again = inkmotion("run", "fit", "text:hi", "--out", str(out), *TINY, "--seed", "3")
    assert again.returncode == 1 and "already holds results" in again.stderr
    assert json.loads((out / "job.json").read_text())["spec"]["seed"] == 0
    forced = inkmotion("run", "fit", "text:hi", "--out", str(out), *TINY, "--seed", "3",
                       "--force")
    assert forced.returncode == 0, forced.stderr
    assert json.loads((out / "job.json").read_text())["spec"]["seed"] == 3
    assert not (out / "stale.txt").exists()  # replaced whole, not merged
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hi"]  # no staging left over


def test_force_never_deletes_the_commands_own_input(results: Path) -> None:
    """Plotting a fit's plan into the fit's own folder with --force would delete the plan
    before it is read (and the job.json written would name a file that is gone)."""
    before = snapshot(results)
    res = inkmotion("run", "plot", str(results / "plan.json"), "--out", str(results),
                    "--force", "--no-record")
    assert res.returncode == 1
    assert res.stderr.strip() == (
        f"error: {results} holds this command's input {results / 'plan.json'}, which writing "
        "the results there would delete; choose another --out.")
    assert snapshot(results) == before
    with pytest.raises(OutputExistsError, match="holds this command's input"):
        refuse_to_overwrite(results.parent, True, inputs=[results / "plan.json"])
    refuse_to_overwrite(results, True, inputs=["text:hi", results.parent / "other.json"])


def test_force_replaces_results_only(tmp_path: Path) -> None:
    """--force replaces a folder a run wrote (it holds job.json, report.json, a
    benchmark's summary.json or a trace's extraction.json), never a folder of the user's
    own files that --out was pointed at by mistake."""
    mine = tmp_path / "documents"
    mine.mkdir()
    (mine / "mine.txt").write_text("keep me")
    with pytest.raises(OutputExistsError) as caught:
        refuse_to_overwrite(mine, True)
    assert str(caught.value) == (
        f"{mine} holds files that are not inkmotion's results (mine.txt), which --force "
        "would delete; choose another --out.")
    (mine / "summary.json").write_text("{}")
    refuse_to_overwrite(mine, True)


def test_the_folder_one_is_in_is_never_the_out(tmp_path: Path, monkeypatch) -> None:
    """``--out .`` (or a folder holding the current one) would have the results replace
    the folder the user's shell is in: refused even when it is empty or with --force."""
    here = tmp_path / "work"
    here.mkdir()
    monkeypatch.chdir(here)
    for out, force in ((Path("."), False), (Path(".."), True), (here, True)):
        with pytest.raises(OutputExistsError, match="is the folder you are in"):
            refuse_to_overwrite(out, force)
    refuse_to_overwrite(Path("results"), False)


def test_render_makes_the_folder_of_its_image(tmp_path: Path) -> None:
    plan = Path(__file__).parent / "data" / "v4_jobs" / "fit" / "plan.json"
    image = tmp_path / "new" / "deeper" / "tag.png"
    res = inkmotion("render", str(plan), "--size", "64", "--out", str(image))
    assert res.returncode == 0, res.stderr
    assert image.read_bytes()[:4] == b"\x89PNG"
    folder = inkmotion("render", str(plan.parent), "--out", str(tmp_path / "x.png"))
    assert folder.returncode == 1 and folder.stderr.strip() == (
        f"error: {plan.parent}: is a folder, not a plan file; give the file in it.")
