"""Checkpoints: a job interrupted mid-run and run again with the same checkpoint file
resumes from its last checkpoint and ends with the plan of an uninterrupted run, bit for
bit on the CPU: a fit, also across the plan edits between stages, and the CLIP-driven
tag and abstract, which optimise through the same core."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from inkmotion.jobs.checkpoint import Checkpoints, remove_checkpoint
from inkmotion.jobs.shell import run_job
from inkmotion.jobs.spec import JobSpec


class Crash(Exception):
    """The stand-in for a worker dying at a step."""


class CrashAt:
    """An observer that raises at step ``step`` (a killed worker, in-process)."""

    def __init__(self, step: int) -> None:
        self.step = step

    def on_step(self, state: object) -> None:
        if state.step == self.step:  # type: ignore[attr-defined]
            raise Crash(self.step)


def spec(steps: int = 60, **params: object) -> JobSpec:
    return JobSpec(kind="fit", inputs={"drawing": "text:hi"}, device="cpu", record_every=0,
                   params={"steps": steps, "size": 100, **params})


def plan_of(folder: Path) -> dict:
    return json.loads((folder / "plan.json").read_text())


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> dict:
    out = tmp_path_factory.mktemp("ck") / "whole"
    run_job(spec(rapid_within=0.0), out)
    return plan_of(out)


@pytest.mark.parametrize("crash, resumed", [(37, 30), (45, 40), (58, 50)])
def test_a_resumed_fit_equals_an_uninterrupted_one(tmp_path: Path, uninterrupted: dict,
                                                   crash: int, resumed: int) -> None:
    """60 steps in stages of 36, 12 and 12 (edits after 36 and 48; no tempo ladder); a
    checkpoint every 10 steps; the crash at 37 and 45 falls inside the second stage, at
    58 in the third."""
    checkpoint = tmp_path / "checkpoint.pt"
    with pytest.raises(Crash):
        run_job(spec(rapid_within=0.0), tmp_path / "a", observers=[CrashAt(crash)],
                checkpoint=checkpoint, checkpoint_every=10, checkpoint_s=1e9)
    assert checkpoint.is_file() and not (tmp_path / "a").exists()
    report = run_job(spec(rapid_within=0.0), tmp_path / "a", checkpoint=checkpoint,
                     checkpoint_every=10, checkpoint_s=1e9)
    assert report["resumed_from_step"] == resumed
    assert plan_of(tmp_path / "a") == uninterrupted  # bit for bit (JSON of float64 values)
    whole = json.loads((tmp_path / "a" / "report.json").read_text())
    assert whole["steps"] == 60 and len(whole["stages"]) == 3


def test_a_fit_interrupted_in_its_tempo_ladder_resumes_to_the_same_plan(tmp_path: Path
                                                                        ) -> None:
    """The default fit of 60 steps: stages of 29, 10 and 9, then rungs of 3 from step 49
    on (no checkpoint inside them): a crash at step 50 resumes from the stages' last
    checkpoint and runs the rungs again, to the uninterrupted plan, bit for bit."""
    whole = run_job(spec(), tmp_path / "whole")
    rungs = [s for s in whole["stages"] if "time_weight" in s]
    assert [s["steps"] for s in whole["stages"][:3]] == [29, 10, 9] and rungs
    checkpoint = tmp_path / "checkpoint.pt"
    with pytest.raises(Crash):
        run_job(spec(), tmp_path / "a", observers=[CrashAt(50)], checkpoint=checkpoint,
                checkpoint_every=10, checkpoint_s=1e9)
    report = run_job(spec(), tmp_path / "a", checkpoint=checkpoint, checkpoint_every=10,
                     checkpoint_s=1e9)
    assert 0 < report["resumed_from_step"] <= 48
    assert plan_of(tmp_path / "a") == plan_of(tmp_path / "whole")
    assert report["steps"] == whole["steps"] and report["stages"] == whole["stages"]


def test_a_checkpoint_of_another_spec_is_not_resumed(tmp_path: Path) -> None:
    checkpoint = tmp_path / "checkpoint.pt"
    with pytest.raises(Crash):
        run_job(spec(40), tmp_path / "a", observers=[CrashAt(25)], checkpoint=checkpoint,
                checkpoint_every=10, checkpoint_s=1e9)
    report = run_job(spec(40, lambda_smooth=30.0), tmp_path / "b", checkpoint=checkpoint,
                     checkpoint_every=10, checkpoint_s=1e9)
    assert report["resumed_from_step"] == 0


def test_a_torn_checkpoint_is_ignored(tmp_path: Path) -> None:
    path = tmp_path / "checkpoint.pt"
    path.write_bytes(b"not a checkpoint")
    assert Checkpoints(path, {"a": 1}).load() is None
    ck = Checkpoints(path, {"a": 1}, every_steps=5, every_s=1e9)
    assert not ck.due(4) and ck.due(5)
    ck.save(5, {"x": 1})
    assert ck.load() == {"x": 1, "step": 5}
    assert Checkpoints(path, {"a": 2}).load() is None  # another spec
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


class _RunsCode:
    """A pickled object that runs code when unpickled: what a checkpoint must never be."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple:
        return (Path.write_text, (self.marker, "ran"))


def test_a_checkpoint_is_data_and_one_that_carries_code_is_refused(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """A file planted where a job's checkpoint lives, holding a pickled object that runs
    code, is not loaded (torch.load with weights_only): one warning naming the file, the
    job starts over at step 0 and finishes, and the planted code never ran."""
    import torch

    checkpoint, marker = tmp_path / "checkpoint.pt", tmp_path / "pwned"
    job = spec(20)
    from inkmotion.jobs.shell import with_threads

    fingerprint = Checkpoints(checkpoint, with_threads(job).to_dict()).fingerprint
    torch.save({"fingerprint": fingerprint, "step": 10, "state": {"x": _RunsCode(marker)}},
               checkpoint)
    with caplog.at_level("WARNING", logger="inkmotion"):
        report = run_job(job, tmp_path / "out", checkpoint=checkpoint, checkpoint_every=10,
                         checkpoint_s=1e9)
    assert not marker.exists(), "the checkpoint ran code"
    assert report["resumed_from_step"] == 0 and (tmp_path / "out" / "plan.json").is_file()
    said = [r.getMessage() for r in caplog.records if "checkpoint" in r.getMessage()]
    assert len(said) == 1 and str(checkpoint) in said[0] and "starts over" in said[0]


def _malformed(saved: dict, how: str) -> dict:
    """A copy of a real checkpoint ``saved`` (fingerprint right) broken as ``how`` says."""
    import copy

    import torch

    bad = copy.deepcopy(saved)
    state = bad["state"]
    if how == "no step":
        del bad["step"]
    elif how == "state not a dict":
        bad["state"] = "state"
    elif how == "no leaves":
        del state["leaves"]
    elif how == "stage a string":
        state["stage"] = "1"
    elif how == "stage past the last":
        state["stage"] = 9
    elif how.startswith("leaves"):
        name, leaf = next(iter(state["leaves"].items()))
        state["leaves"][name] = (leaf[:1].clone() if how == "leaves that broadcast"
                                 else leaf[:, :1].clone() if how == "leaves of another shape"
                                 else torch.full_like(leaf, float("nan")))
    elif how == "adam of another size":
        state["adam"]["exp_avg"] = state["adam"]["exp_avg"][:1]
    elif how == "plans not plans":
        state["stage_plans"] = [{"points": "x"}]
    return bad


@pytest.mark.parametrize("how", [
    "no step", "state not a dict", "no leaves", "stage a string", "stage past the last",
    "leaves that broadcast", "leaves of another shape", "leaves not finite",
    "adam of another size", "plans not plans"])
def test_a_checkpoint_that_loads_as_data_but_is_malformed_starts_the_job_over(
        tmp_path: Path, uninterrupted: dict, how: str,
        caplog: pytest.LogCaptureFixture) -> None:
    """Whoever can write the data directory can compute a job's fingerprint: a checkpoint
    of plain data with a missing key, a string count, parameters of another shape (one
    that broadcasts, too) or NaN ended the job in a traceback (a redelivered job then
    failed on every attempt). Each is now one warning, and the job starts over and ends
    with the uninterrupted plan."""
    import torch

    checkpoint = tmp_path / "checkpoint.pt"
    with pytest.raises(Crash):
        run_job(spec(rapid_within=0.0), tmp_path / "a", observers=[CrashAt(45)],
                checkpoint=checkpoint, checkpoint_every=10, checkpoint_s=1e9)
    torch.save(_malformed(torch.load(checkpoint, weights_only=True), how), checkpoint)
    with caplog.at_level("WARNING", logger="inkmotion"):
        report = run_job(spec(rapid_within=0.0), tmp_path / "a", checkpoint=checkpoint,
                         checkpoint_every=10, checkpoint_s=1e9)
    assert report["resumed_from_step"] == 0
    assert plan_of(tmp_path / "a") == uninterrupted
    said = [r.getMessage() for r in caplog.records if "checkpoint" in r.getMessage()]
    assert len(said) == 1 and "starts over from step 0" in said[0], said


def test_a_state_that_is_not_plain_data_is_a_bug_caught_when_saved(tmp_path: Path) -> None:
    ck = Checkpoints(tmp_path / "c.pt", {"a": 1})
    with pytest.raises(AssertionError, match=r"state\['x'\] is a _RunsCode"):
        ck.save(1, {"x": _RunsCode(tmp_path / "m")})
    assert not (tmp_path / "c.pt").exists()


def test_a_finished_job_leaves_no_half_written_checkpoint(tmp_path: Path) -> None:
    """A worker killed while it saved leaves ``checkpoint.pt.partial-PID``; the attempt
    that finishes the job removes it with the checkpoint (seen once in the worker kill
    test, the kill landing inside torch.save)."""
    path = tmp_path / "checkpoint.pt"
    ck = Checkpoints(path, {"a": 1}, every_steps=5, every_s=1e9)
    ck.save(5, {"x": 1})
    (tmp_path / "checkpoint.pt.partial-12107").write_bytes(b"torn")  # a killed writer's
    (tmp_path / "report.json").write_text("{}")  # not the checkpoint's: kept
    remove_checkpoint(path)  # as the worker does once the job's results are committed
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]


TINY_CLIP = str(Path(__file__).parent / "data" / "clip" / "tiny-vit.json")


def generation_spec(kind: str, inputs: dict[str, str]) -> JobSpec:
    extra = {"targets": 20, "varying_width": True} if kind == "abstract" else {}
    return JobSpec(kind=kind, inputs=inputs, device="cpu", record_every=0,
                   params={"steps": 40, "size": 64, "clip_model": TINY_CLIP,
                           "clip_weights": "random", **extra})


@pytest.mark.parametrize("kind", ["tag", "abstract"])
def test_a_resumed_generation_equals_an_uninterrupted_one(tmp_path: Path, kind: str) -> None:
    """A tag (random augmentations each step: the RNG state is part of the checkpoint)
    and a varying-width abstraction crash at step 27 and resume from step 20."""
    if kind == "abstract":
        from test_generation import write_photo

        inputs = {"image": str(write_photo(tmp_path / "photo.png", 64))}
    else:
        inputs = {"word": "CREAM"}
    job = generation_spec(kind, inputs)
    run_job(job, tmp_path / "whole")
    checkpoint = tmp_path / "checkpoint.pt"
    with pytest.raises(Crash):
        run_job(job, tmp_path / "a", observers=[CrashAt(27)], checkpoint=checkpoint,
                checkpoint_every=10, checkpoint_s=1e9)
    assert checkpoint.is_file() and not (tmp_path / "a").exists()
    report = run_job(job, tmp_path / "a", checkpoint=checkpoint, checkpoint_every=10,
                     checkpoint_s=1e9)
    assert report["resumed_from_step"] == 20 and report["steps"] == 40
    assert (tmp_path / "a" / "plan.json").read_bytes() == \
        (tmp_path / "whole" / "plan.json").read_bytes()
