"""A job's thread count is part of its spec: decided once before it starts, recorded in
job.json and report.json, never taken from (or changed by) the jobs running beside it; so
``run --config job.json`` reproduces a plan bit for bit while another fit runs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from inkmotion.devices import DEFAULT_THREADS, default_threads
from inkmotion.errors import SpecError
from inkmotion.jobs.spec import JobSpec

INKMOTION = [sys.executable, "-m", "inkmotion"]


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items()
           if k not in ("INKMOTION_THREADS", "OMP_NUM_THREADS")}
    return {**env, **extra}


def test_the_default_is_the_environments_override_else_one_thread(monkeypatch):
    monkeypatch.delenv("INKMOTION_THREADS", raising=False)
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    assert default_threads() == DEFAULT_THREADS == 1
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    assert default_threads() == 2
    monkeypatch.setenv("INKMOTION_THREADS", "3")
    assert default_threads() == 3  # inkmotion's own variable wins
    monkeypatch.delenv("INKMOTION_THREADS")
    monkeypatch.setenv("OMP_NUM_THREADS", "4,2")  # OpenMP's nested form: not ours to judge
    assert default_threads() == 1
    for bad in ("zero", "0", "-2", "2x"):  # were ignored without a word
        monkeypatch.setenv("INKMOTION_THREADS", bad)
        with pytest.raises(SpecError, match=f"INKMOTION_THREADS='{bad}' is not a positive"):
            default_threads()


def test_a_seed_beyond_64_bits_is_one_sentence():
    """A seed of 2^64 ended in a 46-line traceback (torch's generator holds 64 bits)."""
    spec = {"version": 11, "kind": "fit", "inputs": {"drawing": "text:a"}}
    with pytest.raises(SpecError, match="seed=18446744073709551616 is too large"):
        JobSpec.from_dict({**spec, "seed": 2**64})
    assert JobSpec.from_dict({**spec, "seed": 2**64 - 1}).seed == 2**64 - 1


@pytest.mark.parametrize("bad", [0, -1, 1.5, "2", True])
def test_a_spec_with_a_thread_count_that_is_not_one_is_refused(bad):
    with pytest.raises(SpecError, match="threads=.* must be a positive integer"):
        JobSpec.from_dict({"version": 4, "kind": "fit", "inputs": {"drawing": "text:a"},
                           "threads": bad})


def test_job_json_and_report_record_the_count_the_job_ran_with(tmp_path, monkeypatch):
    from inkmotion.jobs.shell import run_job

    monkeypatch.setenv("INKMOTION_THREADS", "1")
    before = torch.get_num_threads()
    try:
        spec = JobSpec(kind="fit", inputs={"drawing": "text:a"},
                       params={"steps": 3, "size": 96}, record_every=0, threads=2)
        report = run_job(spec, tmp_path / "two")
        assert report["threads"] == 2  # the spec's count, over the environment's
        saved = json.loads((tmp_path / "two" / "job.json").read_text())["spec"]
        assert saved["threads"] == 2
        report = run_job(JobSpec(kind="fit", inputs={"drawing": "text:a"},
                                 params={"steps": 3, "size": 96}, record_every=0),
                         tmp_path / "default")
        assert report["threads"] == 1
        assert json.loads((tmp_path / "default" / "job.json").read_text())[
            "spec"]["threads"] == 1
    finally:
        torch.set_num_threads(before)


def test_run_config_with_another_fit_beside_it_gives_the_same_plan_bytes(tmp_path):
    """The neighbour test of the thread policy: a fit, then the same job.json again while
    another fit runs on the machine, whose start would once have lowered the thread count
    of the first (and tipped its plan edits)."""
    env = _env()
    first = tmp_path / "first"
    subprocess.run([*INKMOTION, "run", "fit", "text:hi", "--steps", "120", "--size", "200",
                    "--no-record", "--out", str(first)], env=env, check=True,
                   capture_output=True)
    neighbour = subprocess.Popen([*INKMOTION, "run", "fit", "text:neighbour", "--steps",
                                  "3000", "--no-record", "--out", str(tmp_path / "n")],
                                 env=env, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
    try:
        again = tmp_path / "again"
        subprocess.run([*INKMOTION, "run", "fit", "--config", str(first / "job.json"),
                        "--no-record", "--out", str(again)], env=env, check=True,
                       capture_output=True)
        assert neighbour.poll() is None, "the neighbour must still be running"
    finally:
        neighbour.kill()
        neighbour.wait()
    assert (again / "plan.json").read_bytes() == (first / "plan.json").read_bytes()
    report = json.loads((again / "report.json").read_text())
    assert report["threads"] == json.loads((first / "job.json").read_text())["spec"]["threads"]
    assert "threads_lowered" not in report


def test_run_takes_threads_as_an_option_and_config_keeps_it(tmp_path):
    out = tmp_path / "two"
    subprocess.run([*INKMOTION, "run", "fit", "text:a", "--steps", "2", "--size", "96",
                    "--threads", "2", "--no-record", "--out", str(out)], env=_env(),
                   check=True, capture_output=True)
    assert json.loads((out / "job.json").read_text())["spec"]["threads"] == 2
    again = tmp_path / "again"
    subprocess.run([*INKMOTION, "run", "fit", "--config", str(out / "job.json"),
                    "--no-record", "--out", str(again)], env=_env(INKMOTION_THREADS="1"),
                   check=True, capture_output=True)
    assert json.loads((again / "report.json").read_text())["threads"] == 2
    assert Path(again / "plan.json").read_bytes() == Path(out / "plan.json").read_bytes()


def test_the_image_loss_gradient_is_the_same_bits_under_any_thread_count():
    """The multi-scale MSE's levels are elementwise ops (no matrix product), so what the
    optimiser sees does not change with the thread count."""
    from inkmotion.image_losses.multiscale_mse import prepare_multiscale_mse

    g = torch.Generator().manual_seed(0)
    target, image = torch.rand(350, 217, generator=g), torch.rand(350, 217, generator=g)
    loss = prepare_multiscale_mse(target)
    before = torch.get_num_threads()
    grads = []
    try:
        for n in (1, 2, 4):
            torch.set_num_threads(n)
            x = image.clone().requires_grad_(True)
            loss(x).backward()
            grads.append(x.grad)
    finally:
        torch.set_num_threads(before)
    assert all(torch.equal(grads[0], other) for other in grads[1:])


#: what numpy may not use on a machine of AVX2 at most (numpy's own CPU dispatch)
NO_AVX512 = "X86_V4 AVX512_ICL AVX512_SPR"


@pytest.mark.slow
def test_a_fit_is_the_same_bits_under_1_2_4_threads_and_other_cpu_code_paths(tmp_path):
    """The same job under other thread counts, MKL's AVX2 code path (MKL_CBWR, where the
    machine has more), torch's and numpy's kernels of a CPU with AVX2 at most, and torch's
    scalar kernels of a CPU without vector units gives the same plan.json, byte for byte
    (inkmotion.portable_math: the functions whose kernels round otherwise)."""
    runs = {"t1": {"INKMOTION_THREADS": "1"}, "t2": {"INKMOTION_THREADS": "2"},
            "t4": {"INKMOTION_THREADS": "4"},
            "mkl-avx2": {"INKMOTION_THREADS": "1", "MKL_CBWR": "AVX2"},
            "avx2": {"ATEN_CPU_CAPABILITY": "avx2", "NPY_DISABLE_CPU_FEATURES": NO_AVX512},
            "scalar": {"ATEN_CPU_CAPABILITY": "default"}}
    for name, extra in runs.items():
        subprocess.run([*INKMOTION, "run", "fit", "sample:tempt-1", "--steps", "150",
                        "--no-record", "--out", str(tmp_path / name)], env=_env(**extra),
                       check=True, capture_output=True)
    first = (tmp_path / "t1" / "plan.json").read_bytes()
    for name in list(runs)[1:]:
        assert (tmp_path / name / "plan.json").read_bytes() == first, name


def test_job_json_records_the_input_files_bytes_and_the_cpu_code_path(tmp_path):
    """job.json named its input file but not its bytes: run --config of an edited file
    gave another plan from an identical job.json without a word. It now records each
    input file's SHA-256 (and torch's CPU code path, which a result's last bits follow),
    and run --config warns when the file has changed."""
    import hashlib

    svg = tmp_path / "line.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 50"><path '
                   'd="M5 25 C 30 0, 70 50, 95 25" stroke="black" fill="none"/></svg>')
    first = tmp_path / "first"
    subprocess.run([*INKMOTION, "run", "fit", str(svg), "--steps", "20", "--size", "120",
                    "--no-record", "--out", str(first)], env=_env(), check=True,
                   capture_output=True)
    job = json.loads((first / "job.json").read_text())
    assert job["input_files"]["drawing"] == {
        "path": str(svg), "sha256": hashlib.sha256(svg.read_bytes()).hexdigest()}
    assert job["machine"]["cpu_capability"] == torch.backends.cpu.get_cpu_capability()
    again = subprocess.run([*INKMOTION, "run", "--config", str(first / "job.json"),
                            "--no-record", "--out", str(tmp_path / "same")], env=_env(),
                           capture_output=True, text=True)
    assert again.returncode == 0 and "has changed" not in again.stderr
    svg.write_text(svg.read_text().replace("C 30 0", "C 30 10"))
    edited = subprocess.run([*INKMOTION, "run", "--config", str(first / "job.json"),
                             "--no-record", "--out", str(tmp_path / "edited")], env=_env(),
                            capture_output=True, text=True)
    assert edited.returncode == 0, edited.stderr
    assert f"warning: {svg} has changed since this job.json was written" in edited.stderr
