"""The README's command lines run, in the README's order, on a fresh copy of the repository.

A copy of what a clone holds (the tracked files, and those git would add) is made in a
temporary folder and committed there; every ``bash`` line of the README runs in it, as a
user would type it, each after the earlier lines whose results it uses
(``results/hello/plan.json``), two at a time. A line is left out only for a reason listed in
:data:`NOT_RUN` (a service, a robot, a GPU, CLIP weights, a window); a line that matches
no reason runs, so a new README command is tested the day it is written. The Python
blocks run too, except the sketches of a plugin (``...`` bodies).

One change is made to what runs, and only to save time: the optimising commands get
``--steps 30`` unless the line sets its own steps.
Everything else (the inputs, ``sample:NAME``, the options, the output folders, the file
the README shows as ``my_plotter.toml``) is as written.

Then: every line exits 0 (``clip status`` 0 or 1: its answer, weights or none), and the
copy's ``git status`` is clean (the README's commands write under ignored folders only).

``python tests/test_readme.py`` prints, for each README line, whether it ran (with its
wall time) or why not, without pytest.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
#: the steps the optimising commands run with here (their defaults: hundreds)
QUICK_STEPS = 30
#: README lines run at once (the machine's two cores; inkmotion shares them out itself)
PARALLEL = 2
#: (pattern of a command line, why it is not run here); the first match wins
NOT_RUN: tuple[tuple[str, str], ...] = (
    (r"^make (test|gallery)\b", "builds a virtual environment and runs for many minutes "
                                "(CI runs `make test` itself)"),
    (r"^make demo\b", "builds a virtual environment (`make demo` is `inkmotion run fit "
                      "text:inkmotion`, run below as other fits are)"),
    (r"^inkmotion (worker|submit|jobs)\b", "needs Redis and workers (tests/test_workers.py)"),
    (r"^inkmotion view\b", "opens the rerun viewer's window"),
    (r"^inkmotion clip download\b", "downloads weights: needs the network"),
    (r"^inkmotion run (tag|abstract)\b", "needs CLIP weights (tests/test_generation.py "
                                         "runs both kinds on random weights)"),
    (r"^inkmotion (robot teach|run draw)\b", "needs a Franka at the address (tests/"
                                             "test_draw.py runs both against franky-sim)"),
    (r"^inkmotion gallery serve\b", "serves until stopped (tests/test_gallery_browser.py)"),
    (r"^inkmotion studio\b", "serves until stopped and opens a browser (tests/test_studio.py "
                             "drives it in Chromium)"),
    (r"--device cuda\b", "needs a GPU"),
    (r"^inkmotion bench$", "times the whole speed suite, minutes "
                           "(tests/test_bench_figures.py runs its parts)"),
)
#: commands whose answer is their exit status: (pattern, the statuses that are answers)
ANSWERS: tuple[tuple[str, tuple[int, ...]], ...] = (
    (r"^inkmotion clip status$", (0, 1)),  # 1: this machine's cache has no weights
)
#: the README's plotter machine file: the ```toml block that starts with this line
MACHINE_FILE = ("my_plotter.toml", "[machine]")


@dataclass(frozen=True)
class Line:
    """One command line of the README: its text (the comment removed), its line number and
    its language (``bash`` or ``python``, a whole block)."""

    text: str
    number: int
    language: str


def blocks(text: str) -> Iterator[tuple[str, int, list[str]]]:
    """The fenced code blocks of ``text``: (language, first line's number, lines)."""
    language, start, body = None, 0, []
    for number, line in enumerate(text.splitlines(), 1):
        if line.startswith("```"):
            if language is None:
                language, start, body = line[3:].strip(), number + 1, []
            else:
                yield language, start, body
                language = None
        elif language is not None:
            body.append(line)


def command_lines(text: str) -> list[Line]:
    """Every command of the README's ``bash`` blocks (``a; b`` split in two, comments
    dropped) and each ``python`` block that is a program, not a sketch, in order."""
    lines: list[Line] = []
    for language, start, body in blocks(text):
        if language == "bash":
            for offset, raw in enumerate(body):
                words = shlex.split(raw, comments=True)
                if raw.startswith(" ") or not words:  # a comment's continuation
                    continue
                command: list[str] = []
                for word in [*words, ";"]:  # "a; b" is two commands
                    if word.endswith(";"):
                        if word != ";":
                            command.append(word[:-1])
                        if command:
                            lines.append(Line(shlex.join(command), start + offset, "bash"))
                        command = []
                    else:
                        command.append(word)
        elif language == "python" and not any("..." in b for b in body):
            lines.append(Line("\n".join(body), start, "python"))
    return lines


def machine_file(text: str) -> str:
    """The README's example machine file (the toml block that starts with ``[machine]``)."""
    for language, _, body in blocks(text):
        if language == "toml" and body and body[0] == MACHINE_FILE[1]:
            return "\n".join(body) + "\n"
    raise AssertionError("the README shows no [machine] file")


def why_not_run(line: Line) -> str | None:
    """The reason ``line`` is not run here, or None."""
    if line.language != "bash":
        return None
    for pattern, reason in NOT_RUN:
        if re.search(pattern, line.text):
            return reason
    return None


def quick(command: str, cwd: Path = ROOT) -> str:
    """``command`` (run in ``cwd``) with :data:`QUICK_STEPS` optimisation steps when it
    optimises and sets none itself."""
    words = shlex.split(command)
    if "--help" in words or "--steps" in words or any(w.startswith("steps=") for w in words):
        return command
    if words[:2] == ["inkmotion", "benchmark"]:
        return f"{command} --steps {QUICK_STEPS}"
    optimising = {"fit", "tag", "abstract"}
    if words[:2] == ["inkmotion", "run"] and (
            words[2:3] and words[2] in optimising or "--config" in words):
        config = words[words.index("--config") + 1] if "--config" in words else None
        if config is None or _kind_of(cwd / config) in optimising:
            return f"{command} --steps {QUICK_STEPS}"
    return command


def _kind_of(job_file: Path) -> str | None:
    """The kind of a job.json (None while it is not there: the line will say so)."""
    import json

    return json.loads(job_file.read_text())["spec"]["kind"] if job_file.is_file() else None


def fresh_copy(folder: Path) -> Path:
    """What a clone of the repository holds, copied into ``folder`` and committed there."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others",
                             "--exclude-standard"], cwd=ROOT, capture_output=True, check=True)
    for name in filter(None, listed.stdout.decode().split("\0")):
        source = ROOT / name
        if source.is_file():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, folder / name)
    git = ["git", "-c", "user.name=readme", "-c", "user.email=readme@localhost"]
    subprocess.run([*git, "init", "-q"], cwd=folder, check=True)
    subprocess.run([*git, "add", "-A"], cwd=folder, check=True)
    subprocess.run([*git, "commit", "-q", "-m", "fresh"], cwd=folder, check=True)
    return folder


def environment(data: Path) -> dict[str, str]:
    """The user's environment, with this interpreter's scripts first on PATH and the job
    store and artifacts in ``data`` (``gallery build`` reads the store)."""
    bin_dir = str(Path(sys.executable).parent)
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("INKMOTION_") or k == "INKMOTION_THREADS"}
    return {**env, "PATH": f"{bin_dir}{os.pathsep}{env.get('PATH', '')}",
            "INKMOTION_DATA_DIR": str(data), "INKMOTION_DB_URL": f"sqlite:///{data}/jobs.db",
            "PYTHONWARNINGS": "ignore", "COLUMNS": "100"}


def run_line(line: Line, cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess:
    """Run one README line in ``cwd``: a shell line through bash, a Python block with
    this interpreter."""
    if line.language == "python":
        return subprocess.run([sys.executable, "-c", line.text], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=600)
    return subprocess.run(["bash", "-c", quick(line.text, cwd)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=900)


def results_read_or_written(line: Line) -> set[str]:
    """The folders under ``results/`` that ``line`` names (``results/tag`` for
    ``results/tag/plan.json``); ``{"results"}`` when it names the whole folder."""
    return set(re.findall(r"(?<![\w/.-])results(?:/[\w.-]+)?", line.text))


def after(line: Line, earlier: list[Line]) -> list[int]:
    """The indices of the ``earlier`` lines ``line`` must wait for: those that name one of
    its results folders, all of them when either names the whole ``results``."""
    mine = results_read_or_written(line)
    return [i for i, other in enumerate(earlier)
            if (theirs := results_read_or_written(other)) & mine
            or "results" in mine and theirs or "results" in theirs]


def run_readme(folder: Path, report: list[str]) -> list[str]:
    """Run the README in a fresh copy made in ``folder``, :data:`PARALLEL` lines at a time,
    each after the earlier lines whose results it names (:func:`after`); ``report`` gets a
    line per README command, in the README's order; returns the failures, each with its
    output's tail."""
    text = README.read_text()
    copy = fresh_copy(folder / "clone")
    env = environment(folder / "data")
    failures = []
    machine = copy / MACHINE_FILE[0]
    machine.write_text(machine_file(text))
    lines = command_lines(text)
    running: list[Future | None] = []

    def run_after(line: Line, waits: list[Future]) -> tuple[subprocess.CompletedProcess, float]:
        for wait in waits:  # submitted earlier, so already started: no deadlock
            wait.result()
        started = time.perf_counter()
        return run_line(line, copy, env), time.perf_counter() - started

    with ThreadPoolExecutor(PARALLEL) as pool:
        for i, line in enumerate(lines):
            waits = [running[j] for j in after(line, lines[:i]) if running[j] is not None]
            running.append(None if why_not_run(line) is not None
                           else pool.submit(run_after, line, waits))
    for line, done in zip(lines, running, strict=True):
        shown = line.text.splitlines()[0] + (" ..." if "\n" in line.text else "")
        if done is None:
            report.append(f"README:{line.number:<4} not run   {shown}\n{'':20}"
                          f"({why_not_run(line)})")
            continue
        res, took = done.result()
        answers = next((codes for pattern, codes in ANSWERS if re.search(pattern, line.text)),
                       (0,))
        status = (f"ok ({res.returncode})" if res.returncode in answers and res.returncode
                  else "ok" if res.returncode in answers else f"exit {res.returncode}")
        report.append(f"README:{line.number:<4} {status:<9} {took:5.1f} s  {shown}")
        if res.returncode not in answers:
            tail = (res.stdout + res.stderr).strip().splitlines()[-15:]
            failures.append(f"README line {line.number}: {quick(line.text, copy)}\n"
                            + "\n".join(tail))
    machine.unlink()
    left = subprocess.run(["git", "status", "--porcelain"], cwd=copy, capture_output=True,
                          text=True, check=True).stdout.strip()
    if left:
        failures.append(f"the README's commands wrote outside ignored folders:\n{left}")
    return failures


def test_readme_commands_run_on_a_fresh_clone(tmp_path: Path) -> None:
    report: list[str] = []
    failures = run_readme(tmp_path, report)
    print("\n".join(report))
    assert not failures, "\n\n".join(failures)


def test_every_readme_command_is_run_or_has_a_reason() -> None:
    """The parser sees the README's commands (a change of format would make the test above
    run nothing), and most of them run."""
    lines = command_lines(README.read_text())
    ran = [line for line in lines if why_not_run(line) is None]
    assert len(lines) >= 40 and len(ran) >= 25, (len(lines), len(ran))
    assert any(line.text.startswith("inkmotion run fit sample:") for line in ran)
    assert any(line.language == "python" for line in ran)


def test_quick_only_shortens_optimisations() -> None:
    assert quick("inkmotion run fit text:a --out r/a") == \
        f"inkmotion run fit text:a --out r/a --steps {QUICK_STEPS}"
    assert quick("inkmotion run fit text:a --steps 5 --out r/a").endswith("--out r/a")
    assert quick("inkmotion benchmark text:a --out r/b").endswith(f"--steps {QUICK_STEPS}")
    assert quick("inkmotion run plot p.json --out r/p") == "inkmotion run plot p.json --out r/p"
    assert quick("inkmotion render p.json --out r.png") == "inkmotion render p.json --out r.png"


if __name__ == "__main__":
    import tempfile

    lines_out: list[str] = []
    with tempfile.TemporaryDirectory() as tmp:
        problems = run_readme(Path(tmp), lines_out)
    print("\n".join(lines_out))
    print("\n\n".join(problems) if problems else "every README command that was run exited 0;"
          " git status of the copy is clean")
    sys.exit(1 if problems else 0)
