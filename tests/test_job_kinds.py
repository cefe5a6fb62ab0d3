"""Job kinds as plugins: spec version 2 (and version 1 upgraded), parameters declared by the
kind, generated command lines, the shell, and a job kind from another package."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from plan_compare import BLIND_EDITS_TOLERANCE_PX, assert_same_motion

from inkmotion.cli.kind_commands import spec_from_options
from inkmotion.errors import PluginError, SpecError
from inkmotion.jobs.kind import resolve
from inkmotion.jobs.params import to_dict
from inkmotion.jobs.spec import SPEC_VERSION, JobSpec, upgrade_v1
from inkmotion.plugin_host import PluginHost, hookimpl, host

V1 = Path(__file__).parent / "data" / "v1_job"
#: a job.json and plan.json written by spec version 3 (before issue 19's trace term)
V3 = Path(__file__).parent / "data" / "v3_job"


def inkmotion(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "inkmotion", *args], capture_output=True,
                          text=True, timeout=600, cwd=cwd)


def test_v1_spec_is_upgraded_with_plugin_options_nested() -> None:
    v1 = json.loads((V1 / "job.json").read_text())["spec"]
    v2 = upgrade_v1(v1)
    assert v2["version"] == 2 and v2["inputs"] == {"drawing": "text:hi"}
    assert v2["device"] == "cpu" and v2["record_every"] == 10
    assert v2["params"]["initialiser"] == {"name": "dce", "threshold": 1.0}
    assert v2["params"]["losses"] == [{"name": "mse"}]
    assert "dce_threshold" not in v2["params"] and "record_every" not in v2["params"]
    job = resolve(JobSpec.from_dict(v1))
    assert job.params.steps == 40 and job.params.size == 200


def test_v1_job_json_reproduces_its_plan(tmp_path: Path) -> None:
    """A job.json written by version 1 (the previous release) gives the same plan.json (the
    same moves drawing the same motion, within what another machine's kernels move it)."""
    res = inkmotion("run", "--config", str(V1 / "job.json"), "--out", str(tmp_path / "o"),
                    "--no-record")
    assert res.returncode == 0, res.stderr
    assert_same_motion(tmp_path / "o" / "plan.json", V1 / "plan.json")
    written = json.loads((tmp_path / "o" / "job.json").read_text())["spec"]
    assert written["version"] == SPEC_VERSION
    assert written["params"]["initialiser"]["threshold"] == 1.0
    assert written["params"]["initialiser"]["bend"] is False
    assert written["params"]["refine"] == 0 and written["params"]["smooth_over"] == "path"


def test_v3_job_json_reproduces_its_plan(tmp_path: Path) -> None:
    """A job.json of spec version 3 (plan edits kept blindly, no trace term) still gives
    its plan.json (the same moves, the motion within what another machine's kernels move
    it), and is written back as the current version with those version-3 settings spelled
    out."""
    res = inkmotion("run", "--config", str(V3 / "job.json"), "--out", str(tmp_path / "o"),
                    "--no-record")
    assert res.returncode == 0, res.stderr
    assert_same_motion(tmp_path / "o" / "plan.json", V3 / "plan.json",
                       BLIND_EDITS_TOLERANCE_PX)
    written = json.loads((tmp_path / "o" / "job.json").read_text())["spec"]
    assert written["version"] == SPEC_VERSION
    assert written["params"]["w_trace"] == 0.0 and written["params"]["rollback"] is False
    assert written["params"]["keep_corners"] is False
    assert written["params"]["sparsity"] == "budget" and written["params"]["tolerance"] == 0
    bare = JobSpec.from_dict({"version": 4, "kind": "fit", "inputs": {"drawing": "x"},
                              "params": {}})
    assert bare.params == {}  # the spec leaves the defaults to the kind


def test_a_v2_spec_keeps_the_v2_defaults() -> None:
    """A version-2 spec that leaves the changed defaults out runs with version 2's (declared
    on the parameters, ``earlier``); one that gives them keeps what it gives; other kinds
    are unchanged; job.json spells them out as the current version."""
    def full(spec: dict) -> dict:
        job = resolve(JobSpec.from_dict(spec), check_inputs=False)
        written = job.full_spec()
        assert written.version == SPEC_VERSION
        return written.params

    bare = full({"version": 2, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert bare["steps"] == 300 and bare["lambda_smooth"] == 20.0
    assert bare["w_sigma"] == 50.0 and bare["refine"] == 0
    assert bare["smooth_over"] == "path" and bare["w_trace"] == 0.0
    assert bare["rollback"] is False and bare["keep_corners"] is False
    assert bare["initialiser"] == {"name": "dce", "relevance": 2.5, "threshold": 1.0,
                                   "bend": False, "max_bend": 90.0, "bend_estimate": "peak"}
    given = full({"version": 2, "kind": "fit", "inputs": {"drawing": "text:hi"},
                  "params": {"steps": 9, "initialiser": {"name": "dce", "threshold": 20.0}}})
    assert given["steps"] == 9
    assert given["initialiser"]["threshold"] == 20.0 and given["initialiser"]["bend"] is False
    line = full({"version": 2, "kind": "fit", "inputs": {"drawing": "text:hi"},
                 "params": {"initialiser": "line"}})
    assert line["initialiser"]["name"] == "line"
    v3 = full({"version": 3, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert v3["steps"] == 600 and v3["smooth_over"] == "drawing" and v3["w_trace"] == 0.0
    assert v3["initialiser"]["threshold"] is None and v3["initialiser"]["bend"] is True
    v5 = full({"version": 5, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    v6 = full({"version": 6, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert v5["w_worst"] == 0.0 and v6["w_worst"] == 1.0  # the worst misses: version 6 on
    v7 = full({"version": 7, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert (v6["steps"], v6["lr_final"], v6["lambda_smooth"]) == (600, 0.1, 45.0)
    assert (v7["steps"], v7["lr_final"], v7["lambda_smooth"]) == (400, 0.3, 45.0)  # issue 32
    v8 = full({"version": 8, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert v7["strays"] is False and v8["strays"] is True  # edits see the motion's strays
    v9 = full({"version": 9, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert v8["rescue_mean"] is False and v9["rescue_mean"] is True  # the mean's goal too
    assert v8["unpinned"] is False and v9["unpinned"] is True  # no edit that pins Δt
    v10 = full({"version": 10, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert v9["unpinned_end"] is False and v10["unpinned_end"] is True  # nor a last stage
    v11 = full({"version": 11, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert v10["weigh_time"] is False and v11["weigh_time"] is True  # edits pay for time
    v12 = full({"version": 12, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert v11["time_by_initial_moves"] is False and v12["time_by_initial_moves"] is True
    assert v11["rapid_within"] == 0.0 and v12["rapid_within"] == 0.5  # the tempo ladder
    v13 = full({"version": 13, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert (v12["steps"], v13["steps"]) == (400, 300)  # issue 32's job time
    assert (v12["rapid_within"], v13["rapid_within"]) == (0.5, 0.55)
    v14 = full({"version": 14, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert (v13["max_turn"], v14["max_turn"]) == (90.0, 180.0)  # a half circle per arc
    v15 = full({"version": 15, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert (v14["lr_ac"], v15["lr_ac"]) == (0.0, 0.003)  # the lognormals' shapes learn
    assert (v14["w_floor"], v15["w_floor"]) == (0.0, 0.0064)  # and Δt keeps off its floor
    v16 = full({"version": 16, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    # the tempo ladder backs off a rung that leaves the goals instead of ending there
    assert (v15["rapid_backs_off"], v16["rapid_backs_off"]) == (False, True)
    v17 = full({"version": 17, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    # a script loop's sub-movements start at their bend, up to a half circle, and δ learns
    # at a rate for that range
    assert (v16["initialiser"]["max_bend"], v17["initialiser"]["max_bend"]) == (90.0, 180.0)
    assert (v16["lr_delta"], v17["lr_delta"]) == (0.1, 0.2)
    v18 = full({"version": 18, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    assert (v17["rapid_settle"], v18["rapid_settle"]) == (False, True)
    v19 = full({"version": 19, "kind": "fit", "inputs": {"drawing": "text:hi"}, "params": {}})
    # an edit that halves a goal's miss is kept as one that meets it
    assert (v18["rescue_halfway"], v19["rescue_halfway"]) == (False, True)
    tag = full({"version": 2, "kind": "tag", "inputs": {"word": "x"}, "params": {"steps": 5}})
    assert tag["steps"] == 5 and tag["lambda_smooth"] == 1.0 and tag["w_sigma"] == 50.0
    assert tag["lr_final"] == 0.1  # the CLIP kinds keep their own decay at every version
    assert tag["max_turn"] == 90.0  # and the authors' quarter circle
    assert tag["lr_delta"] == 0.1  # with δ's rate for it
    assert tag["lr_ac"] == 0.0 and "w_floor" not in tag  # fixed shapes, no floor barrier


def test_job_json_holds_every_parameter_and_option() -> None:
    job = resolve(JobSpec("fit", {"drawing": "text:hi"}, params={"steps": 5}))
    full = job.full_spec().params
    assert full["steps"] == 5 and full["size"] == 350
    assert full["initialiser"] == {"name": "dce", "relevance": 2.5, "threshold": None,
                                   "bend": True, "max_bend": 180.0,
                                   "bend_estimate": "peak"}
    assert full["renderer"] == {"name": "raster"} and full["losses"] == [{"name": "mse"}]
    assert to_dict(job.params)["initialiser"] == {"name": "dce"}


@pytest.mark.parametrize("params, fragment", [
    ({"stepz": 3}, "unknown parameter(s) stepz"),
    ({"steps": 0}, "steps=0 must be between 1 and 100000"),
    ({"steps": 2.5}, "steps=2.5 must be a whole number"),
    ({"size": "big"}, "size='big' must be a number"),
    ({"width": float("nan")}, "must be a finite number"),
    ({"initialiser": {"name": "dce", "treshold": 2}}, "unknown option(s) treshold"),
    ({"renderer": {"name": "raster", "blur": 1}}, "takes no options; remove blur"),
    ({"renderer": "diffvg"}, "Unknown renderer plugin 'diffvg'"),
    ({"losses": []}, "at least one image loss"),
    ({"initialiser": 3}, "must name one of the initialiser plugins"),
])
def test_bad_parameters_are_one_sentence(params: dict, fragment: str) -> None:
    with pytest.raises((SpecError, PluginError)) as info:
        resolve(JobSpec("fit", {"drawing": "text:hi"}, params=params))
    assert fragment in str(info.value)
    assert "\n" not in str(info.value)


def test_bad_spec_fields() -> None:
    with pytest.raises(SpecError, match="Unknown job kind 'paint'; kinds are: "):
        resolve(JobSpec("paint", {"drawing": "text:hi"}))
    with pytest.raises(SpecError, match="needs its drawing input"):
        resolve(JobSpec("fit", {}))
    with pytest.raises(SpecError, match="has no input.s. photo"):
        resolve(JobSpec("fit", {"drawing": "text:hi", "photo": "x.png"}))
    later = SPEC_VERSION + 1
    with pytest.raises(SpecError, match=f"spec version {later} is not supported"):
        JobSpec.from_dict({"version": later, "kind": "fit", "inputs": {}})
    with pytest.raises(SpecError, match="seed=-1 must be a non-negative integer"):
        JobSpec.from_dict({"version": 2, "kind": "fit", "inputs": {}, "seed": -1})


def test_options_build_the_spec_and_plugin_options_nest() -> None:
    spec = spec_from_options("fit", ["tag.gml"], {"steps": 50, "dce_threshold": 20.0,
                                                  "loss": ["mse"], "seed": 3})
    assert spec.inputs == {"drawing": "tag.gml"} and spec.seed == 3
    assert spec.params["steps"] == 50
    assert spec.params["initialiser"] == {"name": "dce", "threshold": 20.0}
    with pytest.raises(SpecError, match="--dce-threshold applies to the dce initialiser, but "
                                        "this job uses line"):
        spec_from_options("fit", ["tag.gml"], {"initialiser": "line", "dce_threshold": 2.0})


def test_config_then_options_override(tmp_path: Path) -> None:
    spec = spec_from_options("fit", [], {"steps": 7}, config=V1 / "job.json")
    assert spec.inputs == {"drawing": "text:hi"} and spec.params["steps"] == 7
    assert spec.params["size"] == 200
    assert spec.params["initialiser"] == {"name": "dce", "threshold": 1.0}
    assert spec.version == 2  # the version-1 file keeps the defaults of its day
    full = resolve(spec, check_inputs=False).full_spec()
    assert full.version == SPEC_VERSION and full.params["steps"] == 7
    assert full.params["initialiser"]["bend"] is False and full.params["refine"] == 0


# -- registration: protocols, duplicates, all or nothing ---------------------------------

class _Renderer:
    name = "raster"
    description = "A second 'raster'."

    def __call__(self, segments, widths, height, width):
        return None


class _NoRun:
    name = "broken-kind"
    description = "A job kind without run()."
    queue = "optimise"
    inputs = ()
    Params = dict

    def steps(self, params):
        return 1


def test_duplicate_name_is_refused_naming_both_packages() -> None:
    class Module:
        @hookimpl
        def inkmotion_renderers(self):
            return [_Renderer()]

    h = PluginHost()
    h.load_entry_points()
    module = Module()
    with pytest.raises(PluginError) as info:
        h.register(module, name="dup", origin="other-package (dup)")
    text = str(info.value)
    assert "Two renderer plugins are named 'raster'" in text
    assert "inkmotion (inkmotion.plugins.raster)" in text and "other-package (dup)" in text
    assert not h.pm.is_registered(module)
    assert h.get("renderer", "raster").description != _Renderer.description


def test_failed_registration_leaves_nothing_half_registered() -> None:
    class Module:
        @hookimpl
        def inkmotion_renderers(self):
            return [type("Ok", (_Renderer,), {"name": "fine-renderer"})()]

        @hookimpl
        def inkmotion_job_kinds(self):
            return [_NoRun()]

    h = PluginHost()
    module = Module()
    with pytest.raises(PluginError, match="the job-kind plugin 'broken-kind' lacks run"):
        h.register(module, name="half", origin="half-package")
    assert not h.pm.is_registered(module)
    assert "fine-renderer" not in h.plugins("renderer")
    assert "broken-kind" not in h.plugins("job-kind")


def test_plugin_object_without_name_is_refused() -> None:
    class Nameless:
        description = "no name"

        def prepare(self, reference):
            return None

    class Module:
        @hookimpl
        def inkmotion_image_losses(self):
            return [Nameless()]

    with pytest.raises(PluginError, match="has no valid `name`"):
        PluginHost().register(Module(), name="nameless")


# -- a job kind from another package (tests/plugin_package, installed by make test) -------

def test_third_party_job_kind_is_listed_and_runs(tmp_path: Path) -> None:
    assert "spiral" in host().plugins("job-kind"), \
        "tests/plugin_package is not installed; run `make test` (it installs it)"
    res = inkmotion("plugins", "--json")
    rows = {(r["kind"], r["name"]): r for r in json.loads(res.stdout)}
    assert rows[("job-kind", "spiral")]["origin"].startswith("inkmotion-sketch-kind")
    assert rows[("job-kind", "fit")]["origin"].startswith("inkmotion (inkmotion.plugins.fit)")

    helped = inkmotion("run", "spiral", "--help")
    assert helped.returncode == 0 and "--turns" in helped.stdout and "--targets-per-turn" \
        in helped.stdout and "inkmotion run spiral hello" in helped.stdout

    out = tmp_path / "spiral"
    res = inkmotion("run", "spiral", "hello", "--turns", "3", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert {"plan.json", "job.json", "report.json", "recording.rrd"} <= {
        p.name for p in out.iterdir()}
    report = json.loads((out / "report.json").read_text())
    assert report["kind"] == "spiral" and report["title"] == "hello" and report["moves"] == 18
    spec = json.loads((out / "job.json").read_text())["spec"]
    assert spec["params"]["turns"] == 3.0 and spec["inputs"] == {"title": "hello"}

    bad = inkmotion("run", "spiral", "hello", "--turns", "99", "--out", str(tmp_path / "x"))
    assert bad.returncode == 1 and "turns=99.0 must be between 0.25 and 20" in bad.stderr
    assert not (tmp_path / "x").exists()


def test_the_queue_comes_from_the_job_kind() -> None:
    from inkmotion.workers.app import known_queues, queue_for

    assert queue_for("fit") == "optimise" and queue_for("spiral") == "sketch"
    assert known_queues()[:2] == ("optimise", "simulate") and "sketch" in known_queues()


# -- the shell on every device, and the layering ------------------------------------------

@pytest.mark.parametrize("kind, inputs, params", [
    ("fit", {"drawing": "text:hi"}, {"steps": 6, "size": 96}),
    ("spiral", {"title": "hi"}, {"steps": 3}),
])
def test_each_kind_runs_end_to_end_on_the_device(device, tmp_path: Path, kind: str,
                                                  inputs: dict, params: dict) -> None:
    """The whole job — optimisation and every writer — on ``device`` (cpu, and cuda where
    there is one: the writers must get CPU data whatever the fit ran on)."""
    from inkmotion.jobs.shell import run_job

    spec = JobSpec(kind, inputs, params=params, device=str(device))
    report = run_job(spec, tmp_path / "out", record=True)
    assert report["device"].startswith(str(device).split(":")[0])
    assert (tmp_path / "out" / "job.json").is_file() and (tmp_path / "out" / "plan.json").is_file()
    if kind == "fit":
        names = {p.name for p in (tmp_path / "out").iterdir()}
        assert {"trajectory.csv", "speed.png", "drawing.svg", "overlay.png"} <= names
        assert report["chamfer_mean_px"] < 3.0


def test_cpu_runs_reproduce_bit_for_bit(tmp_path: Path) -> None:
    from inkmotion.jobs.shell import run_job

    spec = JobSpec("fit", {"drawing": "text:ok"}, params={"steps": 8, "size": 96}, device="cpu")
    run_job(spec, tmp_path / "a")
    run_job(spec, tmp_path / "b")
    first, second = (tmp_path / d / "plan.json" for d in ("a", "b"))
    assert first.read_bytes() == second.read_bytes()


def test_fitting_does_not_import_jobs() -> None:
    """fitting/ emits step events through the neutral inkmotion.events module."""
    root = Path(__file__).resolve().parents[1] / "framework" / "fitting"
    for source in root.glob("*.py"):
        assert "inkmotion.jobs" not in source.read_text(), source.name


def test_nan_stops_the_fit_with_one_sentence(tmp_path: Path) -> None:
    from inkmotion.errors import InkmotionError
    from inkmotion.jobs.shell import run_job

    spec = JobSpec("fit", {"drawing": "text:hi"}, device="cpu",
                   params={"steps": 30, "size": 96, "lr_points": 1e30})
    with pytest.raises(InkmotionError, match="non-finite loss"):
        run_job(spec, tmp_path / "out")
    assert not list(tmp_path.iterdir())


def test_bench_on_a_missing_gpu_is_one_sentence() -> None:
    import torch

    if torch.cuda.is_available():
        pytest.skip("this machine has a GPU")
    res = inkmotion("bench", "--device", "cuda", "--only", "kinematics")
    assert res.returncode == 1 and "no CUDA GPU is available" in res.stderr
    assert "Traceback" not in res.stderr


WARMED_UP_FIT = """
import json
import sys
from pathlib import Path

from inkmotion.jobs.kind import warm_up_job_kinds
from inkmotion.jobs.shell import run_job
from inkmotion.jobs.spec import JobSpec
import inkmotion.devices  # the job shell's own imports, not the kind's

warmed, failed = warm_up_job_kinds()
before = set(sys.modules)
run_job(JobSpec(kind="fit", inputs={"drawing": "sample:tempt-1"},
                params={"steps": 30, "size": 64}, threads=1), Path(sys.argv[1]))
late = sorted(m for m in set(sys.modules) - before
              if m.split(".")[0] in ("inkmotion", "torch", "scipy", "cv2", "numpy", "skimage"))
print(json.dumps({"warmed": warmed, "failed": failed, "late": late}))
"""


def test_a_fit_after_the_kinds_warm_up_imports_nothing_more(tmp_path: Path) -> None:
    """A worker warms its job kinds up before its first job (workers/tasks.py): the fit's
    warm_up imports everything a fit of a recorded tag (its edits, ladder and recorded
    speed peaks included) imports, so that first job runs as the later ones do."""
    res = subprocess.run([sys.executable, "-c", WARMED_UP_FIT, str(tmp_path / "out")],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    said = json.loads(res.stdout.strip().splitlines()[-1])
    assert "fit" in said["warmed"] and said["failed"] == [] and said["late"] == [], said


def test_a_kind_whose_warm_up_fails_is_named_and_the_others_still_warm_up() -> None:
    from inkmotion.jobs.kind import warm_up_job_kinds

    class Broken:
        def warm_up(self) -> None:
            raise ImportError("No module named 'missing_dependency'")

    fit = host().plugins("job-kind")["fit"]
    warmed, failed = warm_up_job_kinds({"broken": Broken(), "fit": fit, "plain": object()})
    assert warmed == ["fit"]  # "plain" has no warm_up: nothing to do, nothing said
    assert failed == ["warming up the job kind 'broken' failed (No module named "
                      "'missing_dependency'); its first job imports what it needs"]
    # a worker warms up only the kinds of the queues it consumes
    assert warm_up_job_kinds({"fit": fit}, queues={"plot"}) == ([], [])
    assert warm_up_job_kinds({"fit": fit}, queues={fit.queue}) == (["fit"], [])
