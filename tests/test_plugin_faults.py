"""A plugin author's mistakes, met as a user meets them: a third-party package (a real
dist-info on the path, its entry points in the ``inkmotion`` group) whose plugins break
their contract, run through the real command line. Each mistake ends in one sentence
naming the plugin, nothing is written, and the rest of the command line keeps working;
options reach every kind of plugin that declares them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

PLUGINS = textwrap.dedent('''
    """Third-party test plugins: some keep their contract, some break it."""
    import os
    from dataclasses import dataclass

    from inkmotion.jobs.params import param
    from inkmotion.plugin_host import hookimpl


    def _note(text):
        with open(os.environ["FAULTS_LOG"], "a") as f:
            f.write(text + "\\n")


    @dataclass
    class GammaOptions:
        gamma: float = param(0.5, "Coverage exponent.", minimum=0.1, maximum=5.0)
        edge: str = param("soft", "How the rim is drawn.", choices=("soft", "hard"))


    class GammaRenderer:
        name, description, Options = "gamma", "Raster coverage to a power.", GammaOptions

        def __call__(self, segments, widths, height, width, gamma=0.5, edge="soft"):
            from inkmotion.rendering.raster import render_segments
            _note(f"gamma {gamma}")
            return render_segments(segments, widths, height, width).clamp(1e-6, 1) ** gamma


    @dataclass
    class ScaleOptions:
        scale: float = param(1.0, "Scale of the points.", minimum=0.1)


    class DotsReader:
        name, description, Options = "dots", "x y per line (.dots).", ScaleOptions

        def can_read(self, source):
            return source.endswith(".dots")

        def read(self, source, scale=1.0):
            import numpy as np
            from inkmotion.geometry.traces import Traces
            _note(f"scale {scale}")
            rows = np.loadtxt(source, ndmin=2) * scale
            return Traces([rows], width=float(rows[:, 0].max() + 10),
                          height=float(rows[:, 1].max() + 10))


    class SniffingReader:
        name, description = "sniff", "Opens every source to look at its header."

        def can_read(self, source):
            with open(source) as f:  # a text:WORD is no file: raises
                return f.read(5) == "SNIFF"

        def read(self, source):
            raise AssertionError("never chosen")


    class ShapeLoss:
        name, description = "shape", "Forgets to reduce to a number."

        def prepare(self, reference, **options):
            return lambda rendered: (rendered - reference.image) ** 2


    class BoomLoss:
        name, description = "boom", "Raises inside its own code."

        def prepare(self, reference, **options):
            def loss(rendered):
                raise RuntimeError("boom went the loss")
            return loss


    @hookimpl
    def inkmotion_renderers():
        return [GammaRenderer()]


    @hookimpl
    def inkmotion_readers():
        return [DotsReader(), SniffingReader()]


    @hookimpl
    def inkmotion_image_losses():
        return [ShapeLoss(), BoomLoss()]
''')

CLASHING = textwrap.dedent('''
    """A loss whose option flag is run fit's own (--max-error)."""
    from dataclasses import dataclass

    from inkmotion.jobs.params import param
    from inkmotion.plugin_host import hookimpl


    @dataclass
    class MaxOptions:
        error: float = param(1.0, "Weight.")


    class MaxLoss:
        name, description, Options = "max", "The largest miss.", MaxOptions

        def prepare(self, reference, error=1.0):
            return lambda rendered: error * (rendered - reference.image).abs().amax()


    @hookimpl
    def inkmotion_image_losses():
        return [MaxLoss()]
''')


@pytest.fixture(scope="module")
def package(tmp_path_factory) -> dict[str, str]:
    """The environment of a command line that has the third-party package installed."""
    root = tmp_path_factory.mktemp("faulty_plugins")
    (root / "faults_good_and_bad.py").write_text(PLUGINS)
    (root / "faults_clashing.py").write_text(CLASHING)
    info = root / "faulty_plugins-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: faulty-plugins\n"
                                   "Version: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[inkmotion]\nfaults = faults_good_and_bad\namax = faults_clashing\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(root), os.environ.get("PYTHONPATH", "")]), FAULTS_LOG=str(root / "log.txt"))
    return env


def _cli(env: dict[str, str], *args: str, cwd: Path | None = None
         ) -> subprocess.CompletedProcess:
    Path(env["FAULTS_LOG"]).write_text("")
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], env=env, cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def _log(env: dict[str, str]) -> list[str]:
    return Path(env["FAULTS_LOG"]).read_text().split("\n")[:-1]


def test_a_clashing_flag_leaves_the_command_working_and_the_plugin_listed_as_broken(
        package) -> None:
    res = _cli(package, "run", "fit", "--help")
    assert res.returncode == 0, res.stderr
    assert "--gamma-gamma" in res.stdout and "--dots-scale" in res.stdout
    assert "One of: soft, hard." in " ".join(res.stdout.split())  # its choices are told
    assert res.stderr.startswith("warning: inkmotion skipped a plugin: ")
    assert "would take the flag --max-error, which the job kind 'fit'" in res.stderr
    assert "Traceback" not in res.stderr and "manager.py" not in res.stderr
    rows = json.loads(_cli(package, "plugins", "--json").stdout)
    (broken,) = [r for r in rows if r["name"] == "amax"]
    assert "--max-error" in broken["error"]


def test_renderer_and_reader_options_reach_the_plugin(package, tmp_path) -> None:
    """--gamma-gamma 2 was recorded in job.json but the renderer was called with its
    default; a reader chosen with --reader got no options either, in the fit's first read
    or in its second (the recorded times)."""
    res = _cli(package, "run", "fit", "text:hi", "--renderer", "gamma", "--gamma-gamma", "2",
               "--steps", "3", "--out", str(tmp_path / "gamma"))
    assert res.returncode == 0, res.stderr
    assert set(_log(package)) == {"gamma 2.0"}
    (tmp_path / "v.dots").write_text("0 0\n40 10\n80 0\n120 30\n")
    res = _cli(package, "run", "fit", str(tmp_path / "v.dots"), "--reader", "dots",
               "--dots-scale", "2", "--steps", "3", "--out", str(tmp_path / "dots"))
    assert res.returncode == 0, res.stderr
    assert _log(package) and set(_log(package)) == {"scale 2.0"}


@pytest.mark.parametrize("loss, said", [
    ("shape", "error: The image-loss plugin 'shape' returned a tensor of shape ("),
    ("boom", "error: the image-loss plugin 'boom' from faulty-plugins (faults_good_and_bad) "
             "failed: RuntimeError: boom went the loss; this is a fault of that plugin"),
])
def test_a_plugin_that_breaks_while_running_is_named_in_one_sentence(
        package, tmp_path, loss, said) -> None:
    out = tmp_path / "out"
    res = _cli(package, "run", "fit", "text:hi", "--loss", loss, "--steps", "3", "--out",
               str(out))
    assert res.returncode == 1
    errors = [line for line in res.stderr.splitlines() if not line.startswith("warning:")]
    assert errors[-1].startswith(said), res.stderr
    assert "Traceback" not in res.stderr
    assert not out.exists() and not list(tmp_path.glob("out.partial*"))


def test_the_plugins_own_traceback_on_request(package, tmp_path) -> None:
    env = dict(package, INKMOTION_TRACEBACK="1")
    res = _cli(env, "run", "fit", "text:hi", "--loss", "boom", "--steps", "3", "--out",
               str(tmp_path / "out"))
    assert res.returncode == 1 and "Traceback" in res.stderr
    assert "faults_good_and_bad.py" in res.stderr


def test_a_reader_whose_can_read_raises_does_not_stop_the_others(package, tmp_path) -> None:
    res = _cli(package, "run", "fit", "text:hi", "--steps", "3", "--out", str(tmp_path / "o"))
    assert res.returncode == 0, res.stderr
    assert "warning: the reader plugin 'sniff' from faulty-plugins" in res.stderr
    assert "its can_read must return False for what it cannot read" in res.stderr


def test_trace_takes_a_tracers_options_as_run_fit_does() -> None:
    """`inkmotion trace --tracer NAME --NAME-OPTION V` (it said "no such option" while `run
    fit` took the flag): the options are checked against the tracer's Options."""
    from dataclasses import dataclass

    from inkmotion.cli.trace import tracer_options
    from inkmotion.errors import SpecError
    from inkmotion.jobs.params import param

    @dataclass
    class Options:
        flip: bool = param(True, "Reverse every stroke.")
        spacing: float = param(1.0, "Spacing.", minimum=0.5)

    tracer = type("Reverse", (), {"name": "rev", "Options": Options})()
    assert tracer_options(tracer, []) == {"flip": True, "spacing": 1.0}
    assert tracer_options(tracer, ["--no-rev-flip", "--rev-spacing", "2"]) == {
        "flip": False, "spacing": 2.0}
    assert tracer_options(tracer, ["--rev-spacing=3"])["spacing"] == 3.0
    with pytest.raises(SpecError, match="spacing=0.1 must be at least 0.5"):
        tracer_options(tracer, ["--rev-spacing", "0.1"])
    with pytest.raises(SpecError, match="trace takes no option --invrt; the rev tracer's "
                                        "options are: --rev-flip, --rev-spacing"):
        tracer_options(tracer, ["--invrt"])


def test_job_json_names_the_plugin_packages_a_result_was_made_with(package, tmp_path) -> None:
    res = _cli(package, "run", "fit", "text:hi", "--renderer", "gamma", "--steps", "3",
               "--out", str(tmp_path / "o"))
    assert res.returncode == 0, res.stderr
    job = json.loads((tmp_path / "o" / "job.json").read_text())
    assert job["versions"]["plugins"] == {"faulty-plugins": "0.1"}
    res = _cli(package, "run", "fit", "text:hi", "--steps", "3", "--out", str(tmp_path / "b"))
    assert "plugins" not in json.loads((tmp_path / "b" / "job.json").read_text())["versions"]
