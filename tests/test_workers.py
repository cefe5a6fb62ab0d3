"""The distributed path with real parts: redis-server, Celery worker subprocesses, the
SQLite job store and the real ``inkmotion`` command line (fixtures in service_fixtures)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from plan_compare import assert_same_motion
from service_fixtures import inkmotion_cli, wait_for

from inkmotion import store
from inkmotion.jobs.spec import SPEC_VERSION

pytestmark = pytest.mark.services

DATA = Path(__file__).parent / "data"
TINY = ["--steps", "4", "--size", "64"]
ARTIFACTS = {"plan.json", "input.json", "drawing.svg", "drawing.png", "overlay.png",
             "speed.png", "trajectory.csv", "job.json", "report.json", "recording.rrd"}
TAG_ARTIFACTS = ARTIFACTS - {"input.json"} | {"init.json", "init.png"}


def submit(*args: str) -> list[str]:
    res = inkmotion_cli("submit", "fit", *args, "--json")
    assert res.returncode == 0, res.stderr
    return [j["id"] for j in json.loads(res.stdout)]


def wait_succeeded(*ids: str, timeout: float = 120) -> None:
    res = inkmotion_cli("jobs", "wait", *ids, "--timeout", str(timeout), "--quiet",
                        timeout=timeout + 30)
    assert res.returncode == 0, res.stderr


def assert_one_result_set(record: store.JobRecord, data_dir: Path,
                          expected: set[str] = ARTIFACTS) -> Path:
    artifacts = data_dir / "jobs" / record.id / "artifacts"
    assert record.artifact_dir == str(artifacts)
    assert expected <= {p.name for p in artifacts.iterdir()}
    siblings = sorted(p.name for p in artifacts.parent.iterdir())
    assert siblings == ["artifacts", "job.log"] or siblings == ["artifacts", "input", "job.log"]
    return artifacts


def test_submit_runs_to_success_with_record_and_artifacts(workers, service_env):
    (job_id,) = submit("text:hi", *TINY)
    wait_succeeded(job_id)
    r = store.get_job(job_id)
    assert (r.status, r.attempts, r.step, r.total, r.kind, r.queue) == (
        "succeeded", 1, 4, 4, "fit", "optimise")
    assert r.worker_host.split("@")[0] in {"w1", "w2"}
    for name in ("w1", "w2"):  # each warmed the fit up before it took a job (tasks.py)
        said = workers.log_path(name).read_text(errors="replace")
        assert re.search(r"worker: warmed up the job kinds [^\n]*\bfit\b[^\n]* in ", said), said
    assert r.started_at >= r.created_at and r.finished_at >= r.started_at
    assert r.losses and "total" in r.losses and r.t_end > 0
    artifacts = assert_one_result_set(r, Path(service_env["INKMOTION_DATA_DIR"]))
    report = json.loads((artifacts / "report.json").read_text())
    assert report["steps"] == 4

    shown = inkmotion_cli("jobs", "show", job_id[:8], "--json")
    assert shown.returncode == 0 and json.loads(shown.stdout)["status"] == "succeeded"
    listed = inkmotion_cli("jobs", "list", "--json")
    assert job_id in {j["id"] for j in json.loads(listed.stdout)}
    logs = inkmotion_cli("jobs", "logs", job_id)
    assert "attempt 1" in logs.stdout and "succeeded" in logs.stdout
    view = inkmotion_cli("view", job_id, env={"DISPLAY": "", "WAYLAND_DISPLAY": ""})
    assert view.returncode == 0 and str(artifacts / "recording.rrd") in view.stdout


def test_recording_holds_one_entry_per_step(workers, service_env):
    from inkmotion.recording import entity_paths, read_steps

    (job_id,) = submit("text:ab", "--steps", "12", "--size", "64", "--record-every", "5")
    wait_succeeded(job_id)
    artifacts = Path(store.get_job(job_id).artifact_dir)
    rrd = artifacts / "recording.rrd"
    # the 12 steps asked for, or fewer where the tempo ladder ended the fit early
    ran = steps_run(json.loads((artifacts / "report.json").read_text()), 12)
    assert read_steps(rrd) == list(range(1, ran + 1))  # t_end: once per step
    assert read_steps(rrd, "losses/total") == list(range(1, ran + 1))
    assert read_steps(rrd, "rendered") == [1, *range(5, ran + 1, 5)] + ([12] if ran == 12 else [])
    paths = entity_paths(rrd)
    assert {"/target", "/input/traces", "/rendered", "/strokes/0/trajectory",
            "/strokes/0/targets", "/speed/0"} <= paths


def test_file_input_is_copied_into_the_job(workers, service_env, tmp_path):
    src = tmp_path / "tag.gml"
    shutil.copy(DATA / "tag.gml", src)
    (job_id, ) = submit(str(src), *TINY)
    src.unlink()  # the worker reads the job's own copy
    wait_succeeded(job_id)
    r = store.get_job(job_id)
    copy = (Path(service_env["INKMOTION_DATA_DIR"]) / "jobs" / job_id / "input" / "drawing"
            / "tag.gml")
    assert r.spec["version"] == SPEC_VERSION and r.spec["inputs"] == {"drawing": str(copy)}
    assert copy.read_bytes() == (DATA / "tag.gml").read_bytes()
    assert r.metrics and r.metrics["moves"] > 0 and r.metrics["chamfer_mean_px"] >= 0


def test_batch_of_words_is_one_job_per_word(workers, tmp_path):
    words = tmp_path / "words.txt"
    words.write_text("ab\n\n# a comment\ncd\n")
    ids = submit("--batch-words", str(words), *TINY)
    assert len(ids) == 2
    wait_succeeded(*ids)
    assert [store.get_job(i).spec["inputs"]["drawing"] for i in ids] == ["text:ab", "text:cd"]


@pytest.mark.parametrize("args, message", [
    (["text:hi", "--steps", "0"], "steps=0"),
    (["/no/such/file.gml"], "no such file; check the path"),
    (["text:hi", "--renderer", "nope"], "renderer"),
    (["text:hi", "--size", "10"], "size=10"),
])
def test_invalid_spec_is_refused_before_queueing(service_env, args, message):
    before = len(store.list_jobs(limit=None))
    res = inkmotion_cli("submit", "fit", *args)
    assert res.returncode == 1
    assert message in res.stderr and "Traceback" not in res.stderr
    assert res.stdout == ""
    assert len(store.list_jobs(limit=None)) == before


def test_input_above_the_size_limit_is_refused(service_env, tmp_path):
    big = tmp_path / "big.gml"
    shutil.copy(DATA / "tag.gml", big)
    res = inkmotion_cli("submit", "fit", str(big), env={"INKMOTION_MAX_INPUT_MB": "0.0001"})
    assert res.returncode == 1 and "input limit" in res.stderr


def test_an_unwritable_data_dir_or_a_short_id_is_one_sentence(service_env, tmp_path):
    """The job's input copy failing (a data directory this user cannot write) was a
    traceback; a job id prefix under 4 characters said no such job existed."""
    before = len(store.list_jobs(limit=None))
    res = inkmotion_cli("submit", "fit", str(DATA / "tag.gml"),
                        env={"INKMOTION_DATA_DIR": "/proc/inkmotion-none"})
    assert res.returncode == 1 and "Traceback" not in res.stderr, res.stderr
    assert "cannot be written under INKMOTION_DATA_DIR=/proc/inkmotion-none" in res.stderr
    assert len(store.list_jobs(limit=None)) == before
    res = inkmotion_cli("jobs", "show", "bd")
    assert res.returncode == 1 and "give at least 4 characters of its id" in res.stderr


@pytest.mark.parametrize("kind, name, content, message", [
    ("fit", "trunc.gml", "<gml><tag><drawing><stroke><pt><x>0.1</x><y>0.2", "trunc.gml: "),
    ("fit", "empty.json", "", "the file is empty"),
    ("fit", "blank.png", None, "blank.png: "),
    ("plot", "plan.json", '{"plans": [', "is not valid JSON"),
    ("simulate", "plan.json", '{"plans": "none"}', "plan.json: "),
])
def test_an_input_its_run_would_refuse_is_refused_before_queueing(service_env, tmp_path,
                                                                   kind, name, content,
                                                                   message):
    """submit read nothing but the file's size: a truncated tag, an empty file or a blank
    picture was queued and failed later on a worker. Each kind's check_inputs now reads it
    as the run will, and the same sentence comes at once, with nothing recorded."""
    bad = tmp_path / name
    if content is None:  # a white picture: nothing to trace
        import cv2
        import numpy as np

        cv2.imwrite(str(bad), np.full((64, 64), 255, np.uint8))
    else:
        bad.write_text(content)
    before = len(store.list_jobs(limit=None))
    res = inkmotion_cli("submit", kind, str(bad))
    assert res.returncode == 1 and "Traceback" not in res.stderr, res.stderr
    assert message in res.stderr and str(bad) in res.stderr, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert len(store.list_jobs(limit=None)) == before


@pytest.mark.parametrize("kind, option, content, message", [
    ("simulate", "--setup", None, "contact_offset = 0.02 is outside"),
    ("plot", "--machine-file", '[machine]\nname = "x"\nmax_feed = 80\nmax_accel = 800\n'
     'junction_deviation = 0.02\npen_up = "M5"\npen_down = "M3"\ndwell = "G4 P1"\n'
     'header = "G20"\n', "header holds G20"),
])
def test_a_setup_or_machine_file_its_run_would_refuse_is_refused_before_queueing(
        service_env, tmp_path, kind, option, content, message):
    from inkmotion.robot.setup import DEFAULT_SETUP

    plan = tmp_path / "plan.json"
    shutil.copy(DATA / "v4_jobs" / "fit" / "plan.json", plan)
    bad = tmp_path / "bad.toml"
    bad.write_text(content if content is not None else DEFAULT_SETUP.read_text().replace(
        "contact_offset = -0.0003", "contact_offset = 0.02"))
    extra = ["--machine", "custom"] if kind == "plot" else []
    before = len(store.list_jobs(limit=None))
    res = inkmotion_cli("submit", kind, str(plan), option, str(bad), *extra)
    assert res.returncode == 1 and "Traceback" not in res.stderr, res.stderr
    assert message in res.stderr, res.stderr
    assert len(store.list_jobs(limit=None)) == before


def test_a_queued_job_s_error_names_the_file_as_the_user_gave_it(worker_pool, service_env,
                                                                  tmp_path):
    """The worker reads the copy submit made under the data directory; its error named that
    copy (.../jobs/ID/input/drawing/trunc.gml), not the file the user must fix. (submit
    refuses a bad file itself, so here the copy is spoilt after submit, while no worker
    runs: a data directory damaged between submit and run.)"""
    from inkmotion.settings import load_settings

    worker_pool.stop_all()
    good = tmp_path / "trunc.gml"
    shutil.copy(DATA / "tag.gml", good)
    (job_id,) = submit(str(good), *TINY)
    copy = load_settings().job_dir(job_id) / "input" / "drawing" / "trunc.gml"
    copy.write_text("<gml><tag><drawing><stroke><pt><x>0.1</x><y>0.2")
    worker_pool.ensure()
    res = inkmotion_cli("jobs", "wait", job_id, "--timeout", "60", "--quiet", timeout=90)
    assert res.returncode != 0
    record = store.get_job(job_id)
    assert record.status == "failed" and record.error.startswith("trunc.gml: "), record.error
    assert service_env["INKMOTION_DATA_DIR"] not in record.error


def test_unknown_kind_is_refused(service_env):
    res = inkmotion_cli("submit", "paint", "text:hi")
    assert res.returncode == 1 and "Unknown job kind 'paint'" in res.stderr


def test_broker_down_gives_one_sentence_and_records_nothing(service_env):
    from service_fixtures import free_port

    url = f"redis://127.0.0.1:{free_port()}/0"
    before = len(store.list_jobs(limit=None))
    res = inkmotion_cli("submit", "fit", "text:hi", env={"INKMOTION_BROKER_URL": url})
    assert res.returncode == 1
    assert f"Cannot reach the broker at {url}" in res.stderr
    assert "redis-server" in res.stderr and "Traceback" not in res.stderr
    assert len(store.list_jobs(limit=None)) == before
    assert store.list_jobs("queued", limit=None) == []


def steps_run(report: dict, asked: int) -> int:
    """The steps a fit ran: the ``asked`` steps, less the tempo ladder's rungs after the one
    that left the goals (the job ends there); its stages add up to them."""
    rungs = [s for s in report["stages"] if "time_weight" in s]
    ran = int(report["steps"])
    assert ran == sum(s["steps"] for s in report["stages"])
    assert ran == asked - (4 - len(rungs)) * (rungs[0]["steps"] if rungs else 0)
    return ran


def _running(job_id: str, min_step: int = 5) -> store.JobRecord | None:
    r = store.get_job(job_id)
    return r if r.status == "running" and r.step >= min_step else None


def test_cancel_a_running_job(workers, service_env):
    """... and its checkpoint goes with it: a cancelled job never resumes."""
    (job_id,) = submit("text:hello", "--steps", "3000", "--size", "128")
    checkpoint = Path(service_env["INKMOTION_DATA_DIR"]) / "jobs" / job_id / "checkpoint.pt"
    wait_for(lambda: _running(job_id, min_step=60) and checkpoint.is_file(), 90)
    res = inkmotion_cli("jobs", "cancel", job_id)
    assert res.returncode == 0, res.stderr
    log = Path(service_env["INKMOTION_DATA_DIR"]) / "jobs" / job_id / "job.log"
    wait_for(lambda: "cancelled while running" in log.read_text(), 30)
    r = store.get_job(job_id)
    assert r.status == "cancelled" and r.finished_at is not None
    assert not (log.parent / "artifacts").exists()
    assert list(log.parent.glob("artifacts*")) == []  # the staging folder was removed
    wait_for(lambda: not checkpoint.exists(), 10)
    assert inkmotion_cli("jobs", "wait", job_id, "-q").returncode == 1
    again = inkmotion_cli("jobs", "cancel", job_id)
    assert again.returncode == 1 and "already cancelled" in again.stderr


def test_kill_9_of_a_worker_mid_job_another_worker_completes_it(workers, service_env):
    """Celery's own acks_late test, with real processes: the job's worker is killed with
    SIGKILL mid-run; its lease expires (the session's is short) and a reaper queues it
    again, or Redis redelivers the unacknowledged job after the visibility timeout,
    whichever comes first; the other worker completes it, with exactly one result set."""
    steps = 700
    (job_id,) = submit("text:hello", "--steps", str(steps), "--size", "128")
    first = wait_for(lambda: _running(job_id, min_step=20), 60)
    victim = first.worker_host.split("@")[0]
    workers.kill(victim)
    wait_succeeded(job_id, timeout=150)
    r = store.get_job(job_id)
    assert r.attempts >= 2 and r.worker_host != first.worker_host
    assert r.step == r.total == steps
    artifacts = assert_one_result_set(r, Path(service_env["INKMOTION_DATA_DIR"]))
    report = json.loads((artifacts / "report.json").read_text())
    ran = steps_run(report, steps)
    from inkmotion.recording import read_steps

    # the second attempt resumed from the first one's last checkpoint (0: none was due yet)
    # and its recording holds the steps it ran
    resumed = report["resumed_from_step"]
    assert 0 <= resumed < ran
    assert read_steps(artifacts / "recording.rrd") == list(range(resumed + 1, ran + 1))


#: the production defaults of the time limits (soft 3 h, hard + 5 min, visibility + 10 min)
DEFAULT_LIMITS = {"INKMOTION_SOFT_TIME_LIMIT": "10800", "INKMOTION_TIME_LIMIT": "11100",
                  "INKMOTION_VISIBILITY_TIMEOUT": "11700", "INKMOTION_RESTORE_INTERVAL": "60",
                  "INKMOTION_LEASE_S": "30", "INKMOTION_REAPER_INTERVAL": "10"}

#: the production time limits with a short lease: a killed worker's job is queued again
#: within seconds (the tests of what happens after that need not wait the default 40 s)
QUICK_LEASE = {**DEFAULT_LIMITS, "INKMOTION_LEASE_S": "6", "INKMOTION_REAPER_INTERVAL": "1"}


def test_with_the_default_settings_a_dead_workers_job_runs_again_within_a_minute(
        worker_pool, service_env, tmp_path):
    """Workers with the production time limits (Redis would redeliver after 3 h 15 min):
    the job's worker is killed with SIGKILL; its lease expires, another worker's reaper
    queues it again, and it is running again within 60 s and succeeds, with one result
    set, resumed from the dead attempt's last checkpoint. While its lease is expired it is
    shown as stalled, never as running."""
    import time

    from inkmotion.workers.local import WorkerPool

    worker_pool.stop_all()  # the session's workers use a short visibility timeout
    pool = WorkerPool({**service_env, **DEFAULT_LIMITS}, tmp_path / "logs")
    try:
        pool.ensure(("d1", "d2"))
        (job_id,) = submit("text:hello", "--steps", "700", "--size", "128")
        first = wait_for(lambda: _running(job_id, min_step=120), 90)
        victim = first.worker_host.split("@")[0]
        pool.kill(victim)
        killed = time.monotonic()
        at_kill = store.get_job(job_id).step
        shown: list[tuple[float, str, int]] = []  # (s since the kill, status, attempts)

        def running_again() -> dict | None:
            shown_now = inkmotion_cli("jobs", "show", job_id, "--json")
            assert shown_now.returncode == 0, shown_now.stderr  # say why, if it fails
            d = json.loads(shown_now.stdout)
            shown.append((time.monotonic() - killed, d["status"], d["attempts"]))
            return d if d["status"] == "running" and d["attempts"] >= 2 else None

        again = wait_for(running_again, 60, interval=1.0)
        delay = time.monotonic() - killed
        print(f"running again {delay:.1f} s after the kill, on {again['worker_host']}; "
              f"shown: {[(round(t), s, a) for t, s, a in shown]}")
        assert delay < 60 and again["worker_host"] != first.worker_host
        # the dead attempt is shown as running only while its lease could be alive
        assert all(t <= 30 + 2 for t, status, attempts in shown
                   if status == "running" and attempts == 1)
        wait_succeeded(job_id, timeout=150)
        r = store.get_job(job_id)
        assert r.status == "succeeded" and r.attempts == 2 and r.step == r.total == 700
        report = json.loads((Path(r.artifact_dir) / "report.json").read_text())
        # resumed from the dead attempt's last checkpoint (every 50 steps or 30 s; the
        # recorded step lags the run by up to 0.5 s of progress writes)
        assert at_kill >= 120 and 100 <= report["resumed_from_step"] < 700
        assert not (Path(r.artifact_dir).parent / "checkpoint.pt").exists()
        assert_one_result_set(r, Path(service_env["INKMOTION_DATA_DIR"]))
    finally:
        pool.stop_all()


@pytest.mark.slow
def test_a_tag_whose_worker_is_killed_after_step_60_resumes_from_its_checkpoint(
        worker_pool, service_env, tmp_path):
    """A 'tag' job (random CLIP weights, 80 steps) optimises through the same core as a
    fit, so it checkpoints like one: its worker is killed with SIGKILL after step 60,
    another worker's reaper queues it again, and it resumes from the dead attempt's
    checkpoint at step 50 and finishes with one result set and the plan of an
    uninterrupted run, bit for bit (the same thread count, on the CPU)."""
    from test_generation import TINY as TINY_CLIP

    from inkmotion.recording import read_steps
    from inkmotion.workers.local import WorkerPool

    # a 2048-px canvas makes a step ~0.15 s here, so the kill lands between 60 and 80
    args = ["CREAM", "--clip-model", TINY_CLIP, "--clip-weights", "random", "--steps", "80",
            "--size", "2048", "--targets", "300", "--device", "cpu"]
    worker_pool.stop_all()  # the session's workers' time limit is shorter than this job
    pool = WorkerPool({**service_env, **QUICK_LEASE}, tmp_path / "logs")
    try:
        pool.ensure(("t1", "t2"))
        res = inkmotion_cli("submit", "tag", *args, "--json")
        assert res.returncode == 0, res.stderr
        job_id = json.loads(res.stdout)[0]["id"]
        first = wait_for(lambda: _running(job_id, min_step=60), 120, interval=0.1)
        pool.kill(first.worker_host.split("@")[0])
        at_kill = store.get_job(job_id).step
        wait_succeeded(job_id, timeout=180)
        r = store.get_job(job_id)
        assert r.status == "succeeded" and r.attempts == 2 and r.step == r.total == 80
        assert r.worker_host != first.worker_host and 60 <= at_kill < 80
        artifacts = assert_one_result_set(r, Path(service_env["INKMOTION_DATA_DIR"]),
                                          TAG_ARTIFACTS)
        report = json.loads((artifacts / "report.json").read_text())
        assert report["steps"] == 80 and report["resumed_from_step"] == 50
        assert report["clip_weights"] == "random"
        assert read_steps(artifacts / "recording.rrd") == list(range(51, 81))
        assert not (artifacts.parent / "checkpoint.pt").exists()
        print(f"tag killed at step {at_kill} on {first.worker_host}; finished on "
              f"{r.worker_host}, resumed from step {report['resumed_from_step']}")
    finally:
        pool.stop_all()
    alone = inkmotion_cli("run", "tag", *args, "--no-record", "--out", str(tmp_path / "alone"),
                          env={"INKMOTION_THREADS": str(report["threads"])}, timeout=300)
    assert alone.returncode == 0, alone.stderr
    assert (artifacts / "plan.json").read_bytes() == (tmp_path / "alone" / "plan.json").read_bytes()


def test_a_batch_of_fits_on_one_worker_survives_a_kill_9(worker_pool, service_env, tmp_path):
    """``inkmotion worker --batch 3``: three queued fits run as one batched optimisation
    (each reports ``batch: 3``); killed with SIGKILL mid-batch, the worker's leases expire,
    the reaper queues the jobs again, and another batch worker completes each exactly once
    (one result set each, resumed from its own checkpoint or from the start)."""
    from inkmotion.workers.local import WorkerPool

    worker_pool.stop_all()
    env = {**service_env, **QUICK_LEASE, "INKMOTION_WORKER_BATCH": "3"}
    pool = WorkerPool(env, tmp_path / "logs")
    try:
        ids = [submit(w, "--steps", "400", "--size", "128")[0]
               for w in ("text:hi", "text:ok", "text:go")]
        pool.ensure(("b1",))
        wait_for(lambda: all(_running(i, min_step=60) for i in ids) or None, 120)
        assert {store.get_job(i).worker_host for i in ids} == {store.get_job(ids[0]).worker_host}
        pool.kill("b1")
        pool.ensure(("b2",))
        wait_succeeded(*ids, timeout=240)
        data = Path(service_env["INKMOTION_DATA_DIR"])
        for i in ids:
            r = store.get_job(i)
            assert r.status == "succeeded" and r.attempts == 2 and r.step == r.total == 400
            assert_one_result_set(r, data)
            log = (data / "jobs" / i / "job.log").read_text()
            assert "a batch of 3" in log
            report = json.loads((Path(r.artifact_dir) / "report.json").read_text())
            ran = steps_run(report, 400)
            # each resumed from its own checkpoint of the batch (every 50 steps)
            assert 50 <= report["resumed_from_step"] < ran
    finally:
        pool.stop_all()


def test_sigterm_hands_the_running_job_back_at_once(worker_pool, service_env, tmp_path):
    """A redeploy: SIGTERM to the worker running a job. It checkpoints the job, puts it
    back on the queue and exits within seconds; the other worker resumes it from that
    checkpoint (not step 0) without waiting for a lease to expire, and it succeeds."""
    import signal
    import time

    from inkmotion.workers.local import WorkerPool

    worker_pool.stop_all()
    pool = WorkerPool({**service_env, **DEFAULT_LIMITS}, tmp_path / "logs")
    name = ""
    try:
        pool.ensure(("t1", "t2"))
        (job_id,) = submit("text:hello", "--steps", "700", "--size", "128")
        first = wait_for(lambda: _running(job_id, min_step=120), 90)
        name = first.worker_host.split("@")[0]
        proc = pool.procs[name]
        proc.send_signal(signal.SIGTERM)
        sent = time.monotonic()
        proc.wait(30)
        exited = time.monotonic() - sent
        again = wait_for(lambda: (r := store.get_job(job_id)).status == "running"
                         and r.attempts >= 2 and r, 30)
        delay = time.monotonic() - sent
        print(f"worker exited {exited:.1f} s after SIGTERM; job running again after "
              f"{delay:.1f} s on {again.worker_host}")
        assert delay < 15 and again.worker_host != first.worker_host
        log = (Path(service_env["INKMOTION_DATA_DIR"]) / "jobs" / job_id / "job.log").read_text()
        assert "checkpointed and queued again" in log
        wait_succeeded(job_id, timeout=150)
        r = store.get_job(job_id)
        report = json.loads((Path(r.artifact_dir) / "report.json").read_text())
        assert r.attempts == 2 and report["resumed_from_step"] >= 120
        assert r.metrics["resumed_from_step"] == report["resumed_from_step"]  # the record
        assert_one_result_set(r, Path(service_env["INKMOTION_DATA_DIR"]))
    finally:
        pool.procs.pop(name, None)
        pool.stop_all()


def test_third_party_job_kind_goes_to_its_own_queue(workers, service_env):
    res = inkmotion_cli("submit", "spiral", "hello", "--turns", "2", "--json")
    assert res.returncode == 0, res.stderr
    (job,) = json.loads(res.stdout)
    assert (job["kind"], job["queue"]) == ("spiral", "sketch")
    wait_succeeded(job["id"])
    r = store.get_job(job["id"])
    assert (r.status, r.queue, r.step, r.total) == ("succeeded", "sketch", 8, 8)
    assert r.metrics == {"moves": 12, "t_end": pytest.approx(r.metrics["t_end"])}
    report = json.loads((Path(r.artifact_dir) / "report.json").read_text())
    assert report["kind"] == "spiral" and report["title"] == "hello"


def test_submit_of_a_version_1_job_json_reproduces_its_plan(workers, service_env):
    v1 = Path(__file__).parent / "data" / "v1_job"
    res = inkmotion_cli("submit", "fit", "--config", str(v1 / "job.json"), "--json")
    assert res.returncode == 0, res.stderr
    (job,) = json.loads(res.stdout)
    wait_succeeded(job["id"])
    r = store.get_job(job["id"])
    assert_same_motion(Path(r.artifact_dir) / "plan.json", v1 / "plan.json")


def test_submit_abstract_of_a_photo_runs_on_a_worker(workers, service_env, tmp_path):
    """The 'abstract' kind through the queue: the photo is copied into the job, the tiny
    random CLIP model is recorded as such, the result is one path."""
    from test_generation import TINY as TINY_CLIP
    from test_generation import write_photo

    photo = write_photo(tmp_path / "photo.png", 64)
    res = inkmotion_cli("submit", "abstract", str(photo), "--clip-model", TINY_CLIP,
                        "--clip-weights", "random", "--steps", "4", "--size", "64",
                        "--targets", "20", "--json")
    assert res.returncode == 0, res.stderr
    (job,) = json.loads(res.stdout)
    assert (job["kind"], job["queue"]) == ("abstract", "optimise")
    wait_succeeded(job["id"])
    r = store.get_job(job["id"])
    assert (r.status, r.step, r.total) == ("succeeded", 4, 4)
    artifacts = Path(r.artifact_dir)
    assert {"saliency.png", "init.png", "plan.json"} <= {p.name for p in artifacts.iterdir()}
    assert json.loads((artifacts / "job.json").read_text())["clip_weights"] == "random"
    assert len(json.loads((artifacts / "plan.json").read_text())["paths"]) == 1
    assert r.metrics["moves"] == 19


def test_submit_fit_of_a_picture_runs_on_a_worker(workers, service_env, tmp_path):
    """A picture through the queue: the file is copied into the job (the user's may go
    away), the worker traces it and fits the picture, and the record holds the extraction."""
    import inkmotion.samples as samples

    picture = tmp_path / "brush-scan.png"
    shutil.copy(Path(samples.__file__).parent / "brush-scan.png", picture)
    (job_id,) = submit(str(picture), "--steps", "4")
    picture.unlink()
    wait_succeeded(job_id)
    r = store.get_job(job_id)
    copy = (Path(service_env["INKMOTION_DATA_DIR"]) / "jobs" / job_id / "input" / "drawing"
            / "brush-scan.png")
    assert r.spec["inputs"] == {"drawing": str(copy)} and copy.is_file()
    artifacts = assert_one_result_set(r, Path(service_env["INKMOTION_DATA_DIR"]))
    report = json.loads((artifacts / "report.json").read_text())
    assert report["extraction"]["strokes"] >= 1 and r.metrics["moves"] >= 1
