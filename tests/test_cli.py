"""End-to-end: the real command line in a subprocess."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "gml"
ARTIFACTS = {"plan.json", "input.json", "drawing.svg", "drawing.png", "overlay.png",
             "speed.png", "trajectory.csv", "job.json", "report.json"}


def inkmotion(*args: str, cwd: Path | None = None,
              env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore", **(env or {})}
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=300, cwd=cwd, env=env)


@pytest.fixture(scope="module")
def fitted(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("fit") / "hi"
    res = inkmotion("run", "fit", "text:hi", "--out", str(out), "--steps", "15", "--size", "120",
                    "--no-record")
    assert res.returncode == 0, res.stderr
    assert str(out) in res.stdout.replace("\n", "")
    return out


def test_run_fit_writes_every_artifact(fitted: Path) -> None:
    assert ARTIFACTS <= {p.name for p in fitted.iterdir()}
    report = json.loads((fitted / "report.json").read_text())
    for key in ("steps", "wall_s", "initial_loss", "final_loss", "initial_t_end", "final_t_end",
                "chamfer_mean_px", "chamfer_max_px"):
        assert key in report
    # the 15 steps asked for, less the tempo ladder's rungs after one left the goals
    rungs = [s for s in report["stages"] if "time_weight" in s]
    assert report["steps"] == sum(s["steps"] for s in report["stages"])
    assert report["steps"] == 15 - (4 - len(rungs)) * rungs[0]["steps"]
    assert report["final_t_end"] < report["initial_t_end"]
    job = json.loads((fitted / "job.json").read_text())
    assert job["spec"]["params"]["steps"] == 15 and "torch" in job["versions"]
    traces = json.loads((fitted / "input.json").read_text())["traces"]
    assert traces and all(len(s) >= 2 for s in traces)
    header = (fitted / "trajectory.csv").read_text().splitlines()[0]
    assert header == "path,t,x,y,vx,vy,ax,ay,speed"
    assert not list(fitted.parent.glob("*.partial-*"))


def test_run_config_reproduces_the_plan(fitted: Path, tmp_path: Path) -> None:
    again = tmp_path / "again"
    res = inkmotion("run", "--config", str(fitted / "job.json"), "--out", str(again),
                    "--no-record")
    assert res.returncode == 0, res.stderr
    a = json.loads((fitted / "plan.json").read_text())
    b = json.loads((again / "plan.json").read_text())
    assert a == b


def test_run_config_takes_the_kinds_options(fitted: Path, tmp_path: Path) -> None:
    """``run --config job.json --steps N`` overrides as ``run fit --config`` does; an
    option the job's kind does not have is one sentence, and nothing is written."""
    res = inkmotion("run", "--config", str(fitted / "job.json"), "--steps", "4",
                    "--out", str(tmp_path / "four"), "--no-record")
    assert res.returncode == 0, res.stderr
    spec = json.loads((tmp_path / "four" / "job.json").read_text())["spec"]
    assert spec["params"]["steps"] == 4 and spec["params"]["size"] == 120
    res = inkmotion("run", "--out", str(tmp_path / "x"), "--config", str(fitted / "job.json"),
                    "--vmax", "3")
    assert res.returncode == 2 and res.stderr.strip() == (
        f"error: --vmax is not an option of fit jobs ({fitted / 'job.json'} is a fit job); "
        "`inkmotion run fit --help` lists the options.")
    assert not (tmp_path / "x").exists()


def test_run_json_prints_the_report(fitted: Path, tmp_path: Path) -> None:
    """``--json``: stdout is report.json, and only that (the progress is on stderr)."""
    out = tmp_path / "again"
    res = inkmotion("run", "--config", str(fitted / "job.json"), "--out", str(out), "--json",
                    "--no-record")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout) == json.loads((out / "report.json").read_text())


def test_reports_are_strict_json_with_null_for_a_figure_that_does_not_apply(
        tmp_path: Path) -> None:
    """A drawing whose every path is one sub-movement has no T_end ratio over paths of
    two or more: report.json and ``--json`` say null, never NaN (not JSON: a browser's or
    Node's JSON.parse refuses the file), and the summary line leaves it out."""
    svg = tmp_path / "line.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="200" height="100">'
                   '<line x1="10" y1="10" x2="190" y2="80" stroke="black"/></svg>')
    out = tmp_path / "fit"
    res = inkmotion("run", "fit", str(svg), "--steps", "10", "--size", "120", "--out",
                    str(out), "--no-record", "--json")
    assert res.returncode == 0, res.stderr

    def strict(text: str) -> dict:
        return json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in the JSON"))

    report = strict((out / "report.json").read_text())
    assert report["t_end_ratio_multi"] is None  # its one path began as one move
    assert report["metrics"]["t_end_ratio_multi"] is None
    assert strict(res.stdout) == report
    plain = inkmotion("run", "--config", str(out / "job.json"), "--out", str(tmp_path / "b"),
                      "--no-record")
    assert plain.returncode == 0 and "nan" not in plain.stdout, plain.stdout


@pytest.mark.skipif(sys.platform == "win32", reason="SIGTERM")
def test_sigterm_leaves_nothing_half_written(tmp_path: Path) -> None:
    """``kill`` or ``timeout`` (SIGTERM) mid-fit ends the command as Ctrl-C does: no
    output folder and no staging folder left (one held recording.rrd), and it says so."""
    import signal
    import time

    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "inkmotion", "run", "fit", "text:hello",
                             "--steps", "5000", "--size", "96", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob("out.partial-*/*")):  # the job has begun writing
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            time.sleep(0.1)
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert f"interrupted; nothing was written to {out}" in err
    assert list(tmp_path.iterdir()) == []


def test_a_swallowed_interrupt_still_ends_the_job_at_its_next_step() -> None:
    """A library that catches every exception (rerun logs one raised while it converts an
    image as a warning) can swallow the KeyboardInterrupt a SIGTERM raises where it lands;
    the job's StopWhenAsked observer raises it again at the next step. A repeated SIGTERM
    during the clean-up is ignored (the process is still alive to say so)."""
    script = """
import os, signal, sys
from inkmotion.cli import interrupts
interrupts.install()
observer = interrupts.StopWhenAsked()
observer.on_step(None)  # not asked yet: nothing happens
try:
    os.kill(os.getpid(), signal.SIGTERM)
    for _ in range(1000):
        pass
except BaseException:
    pass  # swallowed, as a library might
os.kill(os.getpid(), signal.SIGTERM)  # a repeat: ignored
try:
    observer.on_step(None)
except KeyboardInterrupt:
    print("stopped at the next step")
"""
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "stopped at the next step"


def test_an_interrupt_caught_after_an_extension_ran_python_exits_130(tmp_path: Path) -> None:
    """A KeyboardInterrupt raised inside Python code that a C extension ran through
    ``PyRun_SimpleString`` is marked unhandled by CPython even once caught, and a command
    run with ``python -m`` that then calls ``sys.exit(130)`` dies of SIGINT instead (status
    -2: the SIGTERM test's rare failure). ``exit_interrupted`` exits 130 with its output
    flushed."""
    (tmp_path / "ended.py").write_text("""
import ctypes
from inkmotion.cli import interrupts
ctypes.pythonapi.PyRun_SimpleString(b"raise KeyboardInterrupt")  # as an extension might
print("interrupted; its clean-up said", end="")
interrupts.exit_interrupted()
""")
    res = subprocess.run([sys.executable, "-m", "ended"], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120)
    assert res.returncode == 130, res.stderr
    assert res.stdout == "interrupted; its clean-up said"


def test_run_config_reproduces_a_job_from_any_folder(tmp_path: Path) -> None:
    """A file given by a relative path is recorded absolute in job.json, so ``run
    --config`` of it works from another folder (the gallery prints that command)."""
    here = tmp_path / "here"
    here.mkdir()
    (here / "tag.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" width="200" '
                                  'height="100"><path d="M10 10 C 60 90, 120 0, 190 80" '
                                  'stroke="black" fill="none"/></svg>')
    first = inkmotion("run", "fit", "tag.svg", "--steps", "5", "--size", "96", "--out", "a",
                      "--no-record", cwd=here)
    assert first.returncode == 0, first.stderr
    spec = json.loads((here / "a" / "job.json").read_text())["spec"]
    assert spec["inputs"]["drawing"] == str(here / "tag.svg")
    again = inkmotion("run", "--config", str(here / "a" / "job.json"), "--out", "b",
                      "--no-record", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert (json.loads((tmp_path / "b" / "plan.json").read_text())
            == json.loads((here / "a" / "plan.json").read_text()))


def test_benchmark_json_and_force(tmp_path: Path) -> None:
    """``benchmark --json`` prints the summary alone on stdout; a second run onto the
    same folder is refused in one sentence, and replaces it with ``--force``."""
    out = tmp_path / "bench"
    args = ("benchmark", "text:hi", "--steps", "2", "--size", "64", "--out", str(out))
    res = inkmotion(*args, "--json")
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)
    assert summary == json.loads((out / "summary.json").read_text())
    assert [row["item"] for row in summary["items"]] == ["text-hi"]
    again = inkmotion(*args)
    assert again.returncode == 1 and again.stderr.strip().splitlines() == [
        f"error: {out} already holds results (summary.json, summary.csv, ...); pass --force "
        "to replace them, or choose another --out."]
    assert inkmotion(*args, "--force").returncode == 0


@pytest.mark.parametrize(("args", "said"), [
    (["run", "fit", "--bogus"], "error: no such option: --bogus"),
    (["jobz"], "error: no such command 'jobz'. Did you mean 'jobs'?"),
    (["run", "fit", "text:hi", "--steps", "many", "--out", "x"],
     "error: invalid value for '--steps'"),
])
def test_a_command_line_click_cannot_take_is_one_error_line(args: list[str],
                                                           said: str) -> None:
    """Usage errors read like every other error: one ``error: …`` line naming the command
    whose ``--help`` to read, exit status 2, no box, no traceback."""
    res = inkmotion(*args)
    assert res.returncode == 2
    (line,) = res.stderr.strip().splitlines()
    assert line.startswith(said) and line.endswith("--help` lists what it takes."), line


def kind_examples() -> list[tuple[str, list[str]]]:
    """Every ``inkmotion run KIND ...`` / ``inkmotion evaluate ...`` example a kind
    declares (its ``--help`` shows them), as (kind, words after the command)."""
    import shlex

    from inkmotion.plugin_host import host

    found = []
    for name, kind in sorted(host().plugins("job-kind").items()):
        for example in kind.examples:
            words = shlex.split(example, comments=True)
            if words[:3] == ["inkmotion", "run", name]:
                found.append((name, words[3:]))
            elif words[:2] == ["inkmotion", name]:  # evaluate: a command of its own
                found.append((name, words[2:]))
    return found


@pytest.mark.parametrize(("kind", "args"), kind_examples(),
                         ids=lambda v: v if isinstance(v, str) else " ".join(v))
def test_every_kind_example_is_a_command_line_it_takes(kind: str, args: list[str]) -> None:
    """The examples in ``--help`` name options the command has, with values it accepts
    (parsed by the command itself; nothing runs)."""
    import typer

    from inkmotion.cli.main import app

    root = typer.main.get_command(app)
    with root.make_context("inkmotion", ["--help"], resilient_parsing=True) as ctx:
        group = root.get_command(ctx, "run")
        command = (group.get_command(ctx, kind) if kind != "evaluate"
                   else root.get_command(ctx, "evaluate"))
        command.make_context(kind, list(args), parent=ctx)  # raises on an unknown option


def test_plugins_lists_built_ins() -> None:
    res = inkmotion("plugins", "--json")
    assert res.returncode == 0, res.stderr
    rows = {(r["kind"], r["name"]) for r in json.loads(res.stdout)}
    assert {("renderer", "raster"), ("reader", "gml"), ("initialiser", "dce")} <= rows


@pytest.mark.parametrize("args, fragment", [
    (["run", "fit", "missing.gml"], "missing.gml: no such file"),
    (["run", "fit", "."], ".: is a folder, not a file"),
    (["run", "fit", str(DATA / "malformed.gml")], "malformed.gml"),
    (["run", "fit", str(DATA / "nan.gml")], "nan.gml"),
    (["run", "fit", str(DATA / "same_points.gml")], "same_points.gml"),
    (["run", "fit", str(DATA / "one_point.gml")], "one_point.gml"),
    (["run", "fit", str(DATA / "truncated.json")], "truncated.json"),
    (["run", "fit", "text:hi", "--renderer", "diffvg"], "Unknown renderer plugin 'diffvg'"),
    (["run", "fit", "text:hi", "--steps", "0"], "steps=0"),
    (["run", "fit", "text:hi", "--device", "cuda:7"], "cuda:7"),
])
def test_bad_input_is_one_sentence_and_writes_nothing(tmp_path: Path, args: list[str],
                                                      fragment: str) -> None:
    if args[-1] == "cuda:7":
        import torch

        if torch.cuda.device_count() > 7:
            pytest.skip("this machine has a cuda:7")
    out = tmp_path / "out"
    steps = [] if "--steps" in args else ["--steps", "3"]
    res = inkmotion(*args, "--out", str(out), *steps, cwd=tmp_path)
    assert res.returncode != 0
    assert fragment in res.stderr
    assert "Traceback" not in res.stderr + res.stdout
    assert len([ln for ln in res.stderr.splitlines() if ln.strip()]) <= 2
    assert not out.exists()
    assert not list(tmp_path.glob("out*"))


def test_bad_config_file(tmp_path: Path) -> None:
    bad = tmp_path / "job.json"
    bad.write_text(json.dumps({"kind": "paint", "input": "text:hi"}))
    res = inkmotion("run", "--config", str(bad), "--out", str(tmp_path / "o"))
    assert res.returncode != 0 and "Unknown job kind 'paint'" in res.stderr
    bad.write_text(json.dumps({"kind": "fit", "input": "text:hi", "params": {"stepz": 3}}))
    res = inkmotion("run", "--config", str(bad), "--out", str(tmp_path / "o"))
    assert res.returncode != 0 and "unknown parameter(s) stepz" in res.stderr
    assert "Traceback" not in res.stderr


def test_help_has_examples() -> None:
    res = inkmotion("run", "fit", "--help")
    assert res.returncode == 0 and "inkmotion run fit text:hello" in res.stdout


def test_help_reads_at_80_columns() -> None:
    """Panels: the command's own options first (--out), then the kind's, then each plugin's;
    every option name whole (no ellipsis) within 80 columns."""
    from inkmotion.cli.kind_commands import plugin_options
    from inkmotion.jobs.kind import job_kind
    from inkmotion.jobs.params import describe

    res = inkmotion("run", "fit", "--help", env={"COLUMNS": "80"})
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert all(len(line) <= 80 for line in lines) and "…" not in res.stdout
    assert "<bool>" not in res.stdout  # a flag takes no value, so shows no type
    assert "<int>" in res.stdout or "INTEGER" in res.stdout  # an option with one keeps it
    titles = [line.split("─")[1].strip() for line in lines if line.startswith("╭─")]
    assert titles[:4] == ["Arguments", "Input/Output", "fit parameters", "Every job"]
    assert "dce initialiser (--initialiser dce)" in titles
    assert res.stdout.index("--out") < res.stdout.index("--steps")
    kind = job_kind("fit")
    declared = describe(kind.Params) + [opt for _, _, opt in plugin_options(kind).values()]
    for info in declared:
        flag = f"--[no-]{info.option[2:]}" if info.type is bool else info.option
        assert f"│ {flag} " in res.stdout, flag


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data is absent")
def test_fit_a_real_tag_quickly(tmp_path: Path) -> None:
    out = tmp_path / "tag"
    res = inkmotion("run", "fit", str(SHARED / "49873.json"), "--out", str(out), "--steps", "30",
                    "--no-record")
    assert res.returncode == 0, res.stderr
    report = json.loads((out / "report.json").read_text())
    assert report["paths"] == 5
    assert report["chamfer_mean_px"] < 1.5
