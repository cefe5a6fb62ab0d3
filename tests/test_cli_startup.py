"""Start-up of the command line: the everyday commands must not import the heavy stack.

``import torch`` alone takes about 2 s on a small machine, so ``inkmotion --help``, ``jobs``
and ``view`` must answer without torch (nor NumPy, rerun, Celery or matplotlib). Each
command runs in a fresh interpreter that reports which of those modules it loaded; no
timing is asserted, so the tests are deterministic. ``run``/``submit KIND --help`` load the
job-kind plugins and are left out on purpose.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

#: modules that make start-up slow; none may load on the commands below (the job store's
#: read-only commands read a current SQLite store with sqlite3, not SQLAlchemy)
HEAVY = ("torch", "numpy", "scipy", "cv2", "rerun", "celery", "kombu", "matplotlib",
         "sqlalchemy", "alembic", "open_clip")

#: ``python -c PROBE HEAVY,... ARGV...`` runs ``main()`` with ARGV, then prints its exit code,
#: output and the heavy modules it loaded as one JSON line on the real stdout
PROBE = """
import contextlib, io, json, sys
heavy, argv = sys.argv[1].split(","), sys.argv[2:]
sys.argv = ["inkmotion", *argv]
code = 0
with contextlib.redirect_stdout(io.StringIO()) as out, \\
        contextlib.redirect_stderr(io.StringIO()) as err:
    try:
        from inkmotion.cli.main import main
        main()
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
loaded = sorted(m for m in heavy if m in sys.modules)
print(json.dumps({"code": code, "loaded": loaded, "stdout": out.getvalue(),
                  "stderr": err.getvalue()}))
"""


def probe(env: dict[str, str], *argv: str) -> dict:
    """Run ``inkmotion ARGV`` in a fresh interpreter; its exit code, output and heavy
    modules."""
    res = subprocess.run([sys.executable, "-c", PROBE, ",".join(HEAVY), *argv],
                         capture_output=True, text=True, timeout=120, env=env)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout.strip().splitlines()[-1])


def make_store(data: Path) -> tuple[dict[str, str], str]:
    """A SQLite job store in ``data`` with a queued and a succeeded job (whose artifacts
    hold a recording); the environment that points the command line at it, and the
    succeeded id."""
    from inkmotion import store
    from inkmotion.recording import RECORDING_NAME

    url = f"sqlite:///{data / 'jobs.sqlite3'}"
    store.create_job({"kind": "fit"}, kind="fit", queue="optimise", label="text:queued",
                     total=10, db_url=url)
    done = store.create_job({"kind": "fit"}, kind="fit", queue="optimise", label="text:done",
                            total=10, db_url=url)
    artifacts = data / "jobs" / done.id / "artifacts"
    artifacts.mkdir(parents=True)
    (artifacts / RECORDING_NAME).write_bytes(b"")
    store.mark_running(done.id, "w1@host", db_url=url)
    store.update_progress(done.id, 10, 10, {"total": 0.5}, 1.0, db_url=url)
    store.mark_succeeded(done.id, str(artifacts), db_url=url)
    store.dispose_engines()
    env = {**os.environ, "INKMOTION_DATA_DIR": str(data), "INKMOTION_DB_URL": url,
           "DISPLAY": "", "WAYLAND_DISPLAY": "", "PYTHONWARNINGS": "ignore"}
    return env, done.id


@pytest.fixture(scope="module")
def job_store(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, str], str]:
    """:func:`make_store` in a temporary folder."""
    return make_store(tmp_path_factory.mktemp("startup-data"))


@pytest.mark.parametrize("argv", [
    ["--help"],
    ["jobs", "--help"],
    ["jobs", "list", "--help"],
    ["view", "--help"],
    ["worker", "--help"],
    ["gallery", "--help"],
    ["gallery", "build", "--help"],
])
def test_help_loads_no_heavy_module(job_store: tuple[dict[str, str], str],
                                    argv: list[str]) -> None:
    env, _ = job_store
    result = probe(env, *argv)
    assert result["code"] == 0, result["stderr"]
    assert "Usage" in result["stdout"]
    assert result["loaded"] == []


@pytest.mark.parametrize("argv", [
    ["jobs", "list"],
    ["jobs", "list", "--json"],
    ["jobs", "show", "{id}"],
    ["jobs", "show", "{id}", "--json"],
    ["jobs", "wait", "{id}", "--quiet"],
    ["jobs", "logs", "{id}"],
    ["view", "{id}"],
    ["view", "{id}", "--print"],
])
def test_store_commands_load_no_heavy_module(job_store: tuple[dict[str, str], str],
                                             argv: list[str]) -> None:
    env, job_id = job_store
    result = probe(env, *(a.format(id=job_id) for a in argv))
    assert result["code"] == 0, result["stderr"]
    assert result["loaded"] == []


def test_view_finds_the_recording_without_rerun(job_store: tuple[dict[str, str], str]) -> None:
    env, job_id = job_store
    result = probe(env, "view", job_id[:8], "--print")
    assert result["code"] == 0, result["stderr"]
    assert f"{job_id}/artifacts/recording.rrd" in result["stdout"].replace("\n", "")
    assert result["loaded"] == []


def test_gallery_build_loads_no_torch(job_store: tuple[dict[str, str], str], tmp_path) -> None:
    """Building the gallery reads the store and the artifacts, never torch nor rerun (a
    job with images imports OpenCV for its thumbnail; these have none)."""
    env, job_id = job_store
    result = probe(env, "gallery", "build", "--out", str(tmp_path / "site"))
    assert result["code"] == 0, result["stderr"]
    assert "gallery: 2 jobs (2 built" in result["stdout"]
    assert (tmp_path / "site" / "jobs" / job_id / "files" / "recording.rrd").is_file()
    assert not {"torch", "rerun", "celery", "matplotlib"} & set(result["loaded"])


def test_user_errors_load_no_heavy_module(job_store: tuple[dict[str, str], str]) -> None:
    env, _ = job_store
    result = probe(env, "jobs", "show", "no-such-job")
    assert result["code"] == 1
    assert result["stderr"].startswith("error: No job 'no-such-job'")
    assert result["loaded"] == []


@pytest.mark.parametrize("option, said", [
    (("--size", "3"), "--size 3 must be between 8 and"),
    (("--colour", "reddish"), "--colour 'reddish' is not a colour"),
    (("--renderer", "oil"), "--renderer 'oil': render draws with raster or spray"),
])
def test_render_refuses_a_bad_option_before_loading_torch(
        job_store: tuple[dict[str, str], str], tmp_path, option: tuple[str, str],
        said: str) -> None:
    """A bad option of ``inkmotion render`` is refused before a renderer loads torch (3.3
    s to say so here before; 0.6 s now)."""
    env, _ = job_store
    result = probe(env, "render", str(tmp_path / "plan.json"), *option, "--out",
                   str(tmp_path / "x.png"))
    assert result["code"] == 1 and said in result["stderr"]
    assert not {"torch", "cv2", "rerun"} & set(result["loaded"])
    assert not (tmp_path / "x.png").exists()


def test_view_of_a_missing_or_empty_folder_is_one_sentence(
        job_store: tuple[dict[str, str], str], tmp_path: Path) -> None:
    """A path that is not there is said to be a path, not looked up as a job id."""
    env, _ = job_store
    missing = probe(env, "view", str(tmp_path / "no" / "such"))
    assert missing["code"] == 1 and missing["loaded"] == []
    assert missing["stderr"].startswith(f"error: {tmp_path / 'no' / 'such'}: no such folder")
    empty = probe(env, "view", str(tmp_path))
    assert empty["code"] == 1 and empty["loaded"] == []
    assert empty["stderr"].startswith(f"error: {tmp_path} holds no recording.rrd")
    assert len(empty["stderr"].strip().splitlines()) == 1
    (tmp_path / "plan.json").write_text("{}")  # a results file that is no recording
    (tmp_path / "recording.rrd").write_bytes(b"RRF2")
    plan = probe(env, "view", str(tmp_path / "plan.json"), "--print")
    assert plan["code"] == 1 and plan["stderr"].strip() == (
        f"error: {tmp_path / 'plan.json'}: not a recording (a .rrd file); give "
        f"{tmp_path / 'recording.rrd'} or its folder {tmp_path}.")


def test_waiting_on_a_failed_job_ends_in_one_error_line(
        job_store: tuple[dict[str, str], str]) -> None:
    from inkmotion import store

    env, _ = job_store
    url = env["INKMOTION_DB_URL"]
    made = store.create_job({"kind": "fit"}, kind="fit", queue="optimise", label="text:x",
                            total=10, db_url=url)
    store.mark_failed(made.id, "text:x: bad input.", url)
    store.dispose_engines()
    try:
        result = probe(env, "jobs", "wait", made.id, "-q")
    finally:
        store.delete_job(made.id, url)
        store.dispose_engines()
    assert result["code"] == 1 and result["loaded"] == []
    lines = result["stderr"].strip().splitlines()
    assert lines == [f"{made.id}: failed: text:x: bad input.",
                     f"error: 1 of 1 job(s) did not succeed ({made.id[:12]} failed); "
                     "`inkmotion jobs logs ID` shows why."]


def test_jobs_list_keeps_ids_and_inputs_whole_at_80_columns(
        job_store: tuple[dict[str, str], str]) -> None:
    """No ellipsis: the id prefix is whole, a long input folds instead of being cut."""
    from inkmotion import store

    env, _ = job_store
    label = "results/" + "a-long-folder-name/" * 4 + "tag.json"
    made = store.create_job({"kind": "fit"}, kind="fit", queue="optimise", label=label,
                            total=10, db_url=env["INKMOTION_DB_URL"])
    store.dispose_engines()
    try:
        result = probe({**env, "COLUMNS": "80"}, "jobs", "list")
    finally:
        store.delete_job(made.id, env["INKMOTION_DB_URL"])
        store.dispose_engines()
    assert result["code"] == 0, result["stderr"]
    lines = result["stdout"].splitlines()
    assert all(len(line) <= 80 for line in lines) and "…" not in result["stdout"]
    assert any(line.startswith(made.id[:12]) for line in lines)
    start = lines[0].index("input")  # the last column at 80 (the worker is left out)
    assert label in "".join(line[start:].rstrip() for line in lines[1:])


def _python(code: str) -> list[str]:
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    return res.stdout.split()


def test_import_inkmotion_is_lazy_but_complete() -> None:
    """``import inkmotion`` loads no torch; the public names still resolve on access, with
    ``from inkmotion import ...`` too, and ``dir()`` lists them."""
    out = _python(
        "import sys, inkmotion\n"
        "print('torch' in sys.modules, inkmotion.__version__)\n"
        "print(all(n in dir(inkmotion) for n in inkmotion.__all__))\n"
        "from inkmotion import MotorPlan, kinematics\n"
        "print(MotorPlan.__name__, inkmotion.kinematics is kinematics,\n"
        "      callable(inkmotion.plugin), callable(inkmotion.bezier_segments),\n"
        "      inkmotion.Drawing.__name__)\n"
        "print(hasattr(inkmotion, 'no_such_name'))\n")
    assert out[0] == "False" and out[1].count(".") == 2
    assert out[2] == "True"
    assert out[3:8] == ["MotorPlan", "True", "True", "True", "Drawing"]
    assert out[8] == "False"


def test_recording_name_needs_no_recorder() -> None:
    out = _python("import sys\nfrom inkmotion.recording import RECORDING_NAME, read_steps\n"
                  "print(RECORDING_NAME, callable(read_steps),\n"
                  "      [m for m in ('torch', 'rerun') if m in sys.modules])")
    assert out == ["recording.rrd", "True", "[]"]



#: the commands timed by ``python tests/test_cli_startup.py`` ("{id}": a job of the store)
TIMED = (["--help"], ["jobs", "list"], ["jobs", "show", "{id}"], ["jobs", "wait", "{id}", "-q"],
         ["view", "--help"], ["view", "/no/such/dir"])


def startup_medians(repeats: int = 5) -> dict[str, float]:
    """Median wall time (s) of each :data:`TIMED` command, as the ``inkmotion`` script in a
    fresh process, and of a bare ``python -c "import torch"``, interleaved in one run so
    that they share the machine's load. Figures, not a test: nothing here asserts time."""
    script = Path(sys.executable).with_name("inkmotion")
    with tempfile.TemporaryDirectory() as tmp:
        env, job_id = make_store(Path(tmp))
        commands = {"import torch": [sys.executable, "-c", "import torch"]}
        for argv in TIMED:
            args = [a.format(id=job_id[:8]) for a in argv]
            commands["inkmotion " + " ".join(argv)] = [str(script), *args]
        times: dict[str, list[float]] = {name: [] for name in commands}
        for _ in range(repeats):
            for name, command in commands.items():
                started = time.perf_counter()
                subprocess.run(command, capture_output=True, env=env, timeout=120)
                times[name].append(time.perf_counter() - started)
    return {name: statistics.median(values) for name, values in times.items()}


if __name__ == "__main__":
    medians = startup_medians(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
    torch_s = medians["import torch"]
    for name, seconds in medians.items():
        print(f"{name:34s} {seconds:6.3f} s  {seconds / torch_s:5.2f} x import torch")
