"""The progress bar of ``inkmotion run``: each kind's own figures, read from the device only
every ``refresh_s`` seconds, and cleared before the results are printed."""

from __future__ import annotations

import json
import os
import re
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest
import torch

from inkmotion.events import RunContext, StepState
from inkmotion.jobs.progress_bar import ProgressBar, format_figures
from inkmotion.profiling import count_host_syncs


def _started(total: int, kind: str = "fit", refresh_s: float = 0.5,
             plain: bool = False) -> ProgressBar:
    bar = ProgressBar(refresh_s=refresh_s, plain=plain)
    bar.on_start(RunContext(SimpleNamespace(kind=kind), Path("."), total))
    return bar


def _fit_state(step: int, total: int) -> StepState:
    losses = {"mse": torch.tensor(0.25), "smooth": torch.tensor(0.5),
              "total": torch.tensor(1.5)}
    return StepState(step, total, losses, torch.tensor(3.0))


def test_an_optimisation_shows_its_loss_and_t_end_first() -> None:
    assert format_figures(_fit_state(1, 1).shown()) == \
        "loss=1.5, T_end/path=3, mse=0.25, smooth=0.5"


def test_a_kind_with_figures_shows_those_and_nothing_else() -> None:
    state = StepState(2, 3, {}, None, figures={"now": "franka-sim", "duration_s": 23.4712})
    assert format_figures(state.shown()) == "now=franka-sim, duration_s=23.47"


def test_simulate_shows_its_stage_at_every_step(capsys: pytest.CaptureFixture[str]) -> None:
    bar = _started(3, "simulate", refresh_s=3600.0)  # plain values: shown at once anyway
    bar.on_step(StepState(1, 3, {}, None, figures={"now": "joint trajectory"}))
    assert bar._bar.postfix == "now=joint trajectory"
    bar.on_step(StepState(2, 3, {}, None, figures={"now": "franka-sim",
                                                    "duration_s": 23.47}))
    assert bar._bar.postfix == "now=franka-sim, duration_s=23.47"
    bar.close()
    assert "T_end" not in capsys.readouterr().err


def test_the_bar_clears_itself_at_the_last_step(capsys: pytest.CaptureFixture[str]) -> None:
    bar = _started(2, "plot")
    bar.on_step(StepState(1, 2, {}, None, figures={"now": "G-code"}))
    assert bar._bar is not None
    bar.on_step(StepState(2, 2, {}, None, figures={"estimated_s": 42.0}))
    assert bar._bar is None  # closed (leave=False clears the line) before any table
    err = capsys.readouterr().err
    assert re.search(r"\r {20,}\r$", err), repr(err)  # the line blanked, the cursor at its start
    bar.on_step(StepState(3, 3, {}, None, figures={}))  # later steps are ignored
    bar.on_end({})


def _syncs_per_step(bar: ProgressBar, total: int) -> list[int]:
    """The host synchronisations of each of ``total`` fit steps shown by ``bar`` (the
    steps' states made beforehand)."""
    states = [_fit_state(step, total) for step in range(1, total + 1)]
    counts = []
    for state in states:
        with count_host_syncs() as log:
            bar.on_step(state)
        counts.append(log.count)
    return counts


def test_device_values_are_read_only_every_refresh(capsys: pytest.CaptureFixture[str]) -> None:
    counts = _syncs_per_step(_started(50, refresh_s=3600.0), 50)
    # the first and the last step read every figure in one transfer; no step between
    assert counts[0] > 0 and counts[-1] == counts[0] and not any(counts[1:-1]), counts
    capsys.readouterr()


def test_a_resumed_job_counts_from_its_step(capsys: pytest.CaptureFixture[str]) -> None:
    bar = _started(100)
    bar.on_step(_fit_state(61, 100))
    assert bar._bar.n == 61
    bar.close()
    capsys.readouterr()


def _in_terminal(*args: str) -> str:
    """What ``inkmotion ARGS`` writes on an 80-column pseudo-terminal (it must succeed)."""
    import fcntl
    import pty
    import struct
    import termios

    pid, fd = pty.fork()
    if pid == 0:  # the child: the real command line on a terminal
        fcntl.ioctl(0, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 80, 0, 0))
        os.environ["COLUMNS"] = "80"
        os.execv(sys.executable, [sys.executable, "-m", "inkmotion", *args])
    chunks = []
    while True:
        try:
            data = os.read(fd, 65536)
        except OSError:  # the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    _, status = os.waitpid(pid, 0)
    text = b"".join(chunks).decode("utf-8", "replace")
    assert os.waitstatus_to_exitcode(status) == 0, text
    return text


@pytest.fixture
def small_plan(tmp_path: Path) -> Path:
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({"version": 1, "canvas": {"width": 100, "height": 100},
                                "paths": [{"points": [[10, 10], [60, 20], [90, 80]],
                                           "delta_t": [0.4, 0.4], "delta": [0.2, -0.2],
                                           "ac": [0.1, 0.1], "T": [0.8, 0.8],
                                           "width": 3.0}]}))
    return plan


def _cleared_before(text: str, bar: str, marker: str) -> bool:
    """Whether the last bar line ``bar...`` was blanked before ``marker`` was printed."""
    at = text.rfind(bar)
    cleared = text.find("\r" + " " * 20, at)
    return 0 <= at < cleared < text.index(marker)


LINUX = pytest.mark.skipif(sys.platform != "linux", reason="a pseudo-terminal (pty module)")


@LINUX
def test_plot_in_a_terminal_shows_its_figures_and_clears_the_bar(small_plan: Path) -> None:
    text = _in_terminal("run", "plot", str(small_plan), "--no-record", "--out",
                        str(small_plan.parent / "plot"))
    assert "plot: " in text and "T_end" not in text
    assert re.search(r"estimated_s=|now=stroke order|now=G-code", text), text
    assert _cleared_before(text, "plot: ", "done in"), text


@LINUX
def test_evaluate_clears_its_bar_before_its_table(small_plan: Path) -> None:
    text = _in_terminal("run", "evaluate", str(small_plan), "--no-record", "--out",
                        str(small_plan.parent / "evaluate"))
    assert "evaluate: " in text and "T_end" not in text
    assert "path=1/1, now=" in text, text
    assert _cleared_before(text, "evaluate: ", "evaluation, 1 path(s)"), text


def test_a_log_gets_a_line_every_tenth_not_a_redrawn_bar(
        capsys: pytest.CaptureFixture[str]) -> None:
    counts = _syncs_per_step(_started(600, plain=True, refresh_s=0.0), 600)
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert "\r" not in err and len(lines) == 11, err  # step 1, then 60, 120, ..., 600
    assert lines[0].startswith("fit: 1/600 ") and lines[-1].startswith("fit: 600/600 ")
    assert "loss=1.5, T_end/path=3" in lines[-1]
    # the device is read only on the steps that write a line
    assert sum(1 for c in counts if c) == 11, counts


def test_a_captured_run_writes_plain_lines(tmp_path: Path) -> None:
    import subprocess

    done = subprocess.run([sys.executable, "-m", "inkmotion", "run", "fit", "text:hi",
                           "--steps", "20", "--size", "64", "--no-record", "--out",
                           str(tmp_path / "fit")], capture_output=True, text=True, check=True)
    assert "\r" not in done.stderr, done.stderr
    # the last line is the last step: the 20 announced, or fewer where the tempo ladder
    # ended the fit early (report.json's steps)
    steps = json.loads((tmp_path / "fit" / "report.json").read_text())["steps"]
    assert 16 <= steps <= 20
    lines = [line for line in done.stderr.splitlines() if line.startswith("fit: ")]
    assert re.match(rf"fit: {steps}/{steps} [\d.]+ s, loss=", lines[-1]), done.stderr


def test_a_log_ends_at_the_step_a_job_ended_on(capsys: pytest.CaptureFixture[str]) -> None:
    """A job that ends before the steps it announced (a fit's tempo ladder that ends
    early) still gets its last line, at the step it ended on."""
    bar = _started(20, plain=True)
    for step in range(1, 13):
        bar.on_step(_fit_state(step, 20))
    bar.on_end({"steps": 12})
    lines = capsys.readouterr().err.splitlines()
    assert lines[-1].startswith("fit: 12/12 ") and "loss=1.5" in lines[-1]
    assert sum(line.startswith("fit: 12/") for line in lines) == 1
