"""inkmotion studio: the checks of what the page sends (drawings, uploads, settings), and the
real thing: ``inkmotion studio`` started as a subprocess on loopback, its API over HTTP and
its page in headless Chromium through Selenium (drawing with synthetic pointer events,
fitting, animating, cancelling, closing a tab, three tabs at once, a bad upload, sending
the plan to the plotter)."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import time
import urllib.error
import urllib.request
import zlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from inkmotion.errors import InputError
from inkmotion.inputs.gml import read_gml
from inkmotion.studio.app import UserError, fit_params
from inkmotion.studio.drawing import drawing_gml
from inkmotion.studio.uploads import check_upload, safe_name

pytest.importorskip("starlette", reason="Starlette is not installed")

PNG = b"\x89PNG\r\n\x1a\n"
MB = 2**20
FAST = {"steps": 60}  # a short fit: the page's behaviour, not the fit's quality


# -- a drawing from the page -----------------------------------------------------------------
def _stroke(x0: float, y0: float, x1: float, y1: float, t0: float, n: int = 30) -> list:
    return [[x0 + (x1 - x0) * k / (n - 1), y0 + (y1 - y0) * k / (n - 1), t0 + 8.0 * k, 0.4]
            for k in range(n)]


def test_a_drawing_becomes_a_gml_tag_with_increasing_times(tmp_path):
    strokes = [_stroke(20, 30, 200, 40, 1000.0), _stroke(50, 100, 60, 300, 1600.0)]
    strokes[0].insert(5, list(strokes[0][4]))  # a repeated time stamp: no motion, dropped
    path = tmp_path / "d.gml"
    path.write_text(drawing_gml({"width": 400, "height": 320, "strokes": strokes}))
    traces = read_gml(str(path))
    assert len(traces.strokes) == 2
    times = traces.meta["t"]
    assert all(np.all(np.diff(t) > 0) for t in times)
    assert times[0][0] == pytest.approx(0.0) and times[1][0] == pytest.approx(0.6)
    assert times[1][0] > times[0][-1]  # the pen lift's time is kept
    # shape kept: the first stroke is nearly level, the second nearly upright
    a, b = traces.strokes
    assert abs(a[-1, 1] - a[0, 1]) < 0.1 * abs(a[-1, 0] - a[0, 0])
    assert abs(b[-1, 0] - b[0, 0]) < 0.1 * abs(b[-1, 1] - b[0, 1])
    assert "<pressure>0.400</pressure>" in path.read_text()


@pytest.mark.parametrize("payload, words", [
    ([], "not a JSON object"),
    ({"width": 0, "height": 10, "strokes": []}, "no size or no strokes"),
    ({"width": 10, "height": 10, "strokes": [[[1, 2, 3, 0.5]]]}, "no stroke of two points"),
    ({"width": 10, "height": 10, "strokes": [[[1, "x", 3], [2, 2, 4]]]}, "not a finite"),
    ({"width": 10, "height": 10, "strokes": [[[1, 2], [2, 2]]]}, "not [x, y, t, pressure]"),
    ({"width": 10, "height": 10, "strokes": [[[1, 1, 0, 0]] * 2] * 501}, "more than 500"),
])
def test_a_bad_drawing_is_refused_in_one_sentence(payload, words):
    with pytest.raises(InputError, match=None) as info:
        drawing_gml(payload)
    assert words in str(info.value) and str(info.value).count(". ") == 0


# -- uploads and settings --------------------------------------------------------------------
def _png_claiming(w: int, h: int) -> bytes:
    """A PNG whose header says w × h pixels and whose data is cut short."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return len(data).to_bytes(4, "big") + body + zlib.crc32(body).to_bytes(4, "big")
    ihdr = w.to_bytes(4, "big") + h.to_bytes(4, "big") + bytes([8, 0, 0, 0, 0])
    return PNG + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64))


@pytest.mark.parametrize("name, data, words", [
    ("tag.exe", b"MZ", "not a drawing the studio reads"),
    ("tag.gml", b"", "empty"),
    ("tag.gml", b"x" * (2 * MB), "above the 1 MB upload limit"),
    ("photo.png", b"GIF89a....", "not a PNG picture"),
    ("huge.png", _png_claiming(30000, 30000), "900 megapixels, more than the 400"),
    ("broken.png", PNG + b"\x00" * 30, "not a picture this can read"),
    ("tag.svg", b"\x00\x01binary", "not a text file"),
])
def test_a_bad_upload_is_refused_in_one_sentence(name, data, words):
    with pytest.raises(InputError) as info:
        check_upload(name, data, 1 * MB)
    assert words in str(info.value)


@pytest.mark.parametrize("name, fmt", [
    ("phone.avif", "AVIF"), ("scan.gif", "GIF"), ("grey.ppm", "PPM"), ("page.jp2", "JPEG2000"),
    ("photo.webp", "WEBP"), ("sketch.png", "PNG")])
def test_every_picture_the_tracer_reads_can_be_uploaded(name, fmt):
    from PIL import Image

    from inkmotion.images.formats import PICTURE_SUFFIXES as SUFFIXES
    from inkmotion.studio.uploads import KINDS, accepted

    assert set(SUFFIXES) - {".pdf"} <= set(KINDS)  # one list: the tracer's (a PDF refused,
    assert ".pdf" not in accepted()  # so not offered as accepted either)
    buffer = io.BytesIO()
    Image.new("L", (64, 48), 255).save(buffer, fmt)
    assert check_upload(name, buffer.getvalue(), MB) == name


@pytest.mark.parametrize("name, data, words", [
    ("page.pdf", b"%PDF-1.7\n...", "export its page as PNG or JPEG"),
    ("photo.avif", b"not an avif at all", "not a picture this can read"),
    ("scan.gif", PNG + b"...", "not a GIF picture"),
])
def test_a_picture_upload_that_cannot_be_traced_says_what_to_do(name, data, words):
    with pytest.raises(InputError) as info:
        check_upload(name, data, MB)
    assert words in str(info.value)


def test_an_upload_name_never_becomes_a_path():
    assert safe_name("../../etc/passwd.svg") == "passwd.svg"
    assert safe_name("C:\\Users\\me\\my tag (1).GML") == "C_Users_me_my_tag_1.gml"
    assert safe_name("...png") == "upload.png"
    assert check_upload("my tag.gml", b"<gml/>", MB) == "my_tag.gml"


@pytest.mark.parametrize("settings, words", [
    ({"steps": 10}, "steps must be a number from 20"),
    ({"lambda_smooth": "NaN"}, "lambda_smooth must be a number"),
    ({"size": "big"}, "size must be a number"),
    ({"varying_width": "yes"}, "varying_width is on or off"),
    ({"targets": "many"}, "Targets are 'default', 'auto' or a number"),
    ({"out": "/etc"}, "Unknown setting 'out'"),
])
def test_bad_settings_are_refused(settings, words):
    with pytest.raises(UserError, match=None) as info:
        fit_params(settings)
    assert words in str(info.value)


# -- the real server ---------------------------------------------------------------------------
def _free_port() -> int:
    from inkmotion.workers.local import free_port

    return free_port()


class Studio:
    """``inkmotion studio`` in a subprocess, with its own data directory and job store."""

    def __init__(self, root: Path, *extra: str, env: dict[str, str] | None = None,
                 slots: int = 1) -> None:
        self.root = root
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.db_url = f"sqlite:///{root}/jobs.db"
        self.headers: dict[str, str] = {}  # sent with every request (a token's cookie)
        if env is None:
            env = {**os.environ, "INKMOTION_DATA_DIR": str(root), "INKMOTION_DB_URL": self.db_url}
            env.pop("INKMOTION_BROKER_URL", None)
        else:
            env = {**os.environ, **env}
            self.db_url = env["INKMOTION_DB_URL"]
        self.log = open(root / "studio.log", "w")  # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "inkmotion", "studio", "--port", str(self.port), "--no-open",
             "--slots", str(slots), *extra], env=env, stdout=self.log, stderr=subprocess.STDOUT,
            start_new_session=True)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                urllib.request.urlopen(self.url + "/static/studio.css", timeout=1).read()
                return
            except urllib.error.HTTPError:  # it answers (a token is asked for)
                return
            except OSError:  # not listening yet, or too busy starting to answer in 1 s
                if self.proc.poll() is not None:
                    break
                time.sleep(0.2)
        self.stop()
        raise RuntimeError("the studio did not start: " + (root / "studio.log").read_text())

    def request(self, method: str, path: str, body: object = None, *,
                headers: dict | None = None) -> tuple[int, dict | bytes]:
        data = None
        headers = dict(self.headers if headers is None else headers)
        if isinstance(body, bytes):
            data = body
            headers.setdefault("Content-Type", "application/octet-stream")
        elif body is not None:
            data = json.dumps(body).encode()
            headers.setdefault("Content-Type", "application/json")
        req = urllib.request.Request(self.url + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(req, timeout=60) as r:
                raw, status, kind = r.read(), r.status, r.headers.get("content-type", "")
        except urllib.error.HTTPError as exc:
            raw, status, kind = exc.read(), exc.code, exc.headers.get("content-type", "")
        return status, (json.loads(raw) if kind.startswith("application/json") else raw)

    def events(self, job: str, timeout: float = 120) -> list[dict]:
        out = []
        with urllib.request.urlopen(f"{self.url}/api/jobs/{job}/events", timeout=timeout) as r:
            for line in r:
                if line.startswith(b"data: "):
                    out.append(json.loads(line[6:]))
                    if out[-1]["type"] == "end":
                        break
        return out

    def start_long_fit(self) -> str:
        """A fit of 4000 steps, returned once it runs (its first step came)."""
        status, d = self.request("POST", "/api/fits",
                                 {"input": {"sample": "tempt-3"}, "settings": {"steps": 4000}})
        req = urllib.request.Request(f"{self.url}/api/jobs/{d['job']}/events",
                                     headers=self.headers)
        with urllib.request.urlopen(req, timeout=120) as r:
            for line in r:
                if line.startswith(b"data: ") and json.loads(line[6:])["type"] == "step":
                    break
        return d["job"]

    def record(self, job: str) -> object:
        from inkmotion import store

        return store.get_job(job, self.db_url)

    def stop(self) -> None:
        import signal

        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGINT)  # Ctrl-C: the studio ends its jobs
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.log.close()


@pytest.fixture(scope="module")
def studio(tmp_path_factory) -> Iterator[Studio]:
    s = Studio(tmp_path_factory.mktemp("studio"), slots=2)
    yield s
    s.stop()


def test_a_fit_through_the_api_streams_progress_and_ends_with_its_motion(studio):
    status, d = studio.request("POST", "/api/fits", {"input": {"text": "hi"}, "settings": FAST})
    assert status == 200, d
    job = d["job"]
    events = studio.events(job)
    kinds = [e["type"] for e in events]
    assert kinds[0] == "queued" and "start" in kinds and kinds[-1] == "end", kinds
    assert events[-1]["status"] == "succeeded"
    steps = [e for e in events if e["type"] == "step"]
    # the last step the job ran (60, or fewer where the tempo ladder ended it) ends the count
    assert steps and steps[-1]["step"] == steps[-1]["total"] and any("paths" in e for e in steps)
    status, r = studio.request("GET", f"/api/jobs/{job}/result")
    assert status == 200 and 48 <= steps[-1]["step"] <= 60
    assert r["figures"]["moves"] == sum(len(p["targets"]) - 1
                                                         for p in r["paths"])
    for p in r["paths"]:  # the animation's timeline: increasing times, one speed each
        assert np.all(np.diff(p["t"]) > 0) and len(p["speed"]) == len(p["t"]) == len(p["xy"])
    status, plan = studio.request("GET", f"/api/jobs/{job}/files/plan.json")
    assert status == 200 and plan["paths"]
    record = studio.record(job)
    assert record.status == "succeeded" and record.metrics["moves"] == r["figures"]["moves"]
    assert (studio.root / "jobs" / job / "artifacts" / "report.json").is_file()
    assert not (studio.root / "jobs" / job / "checkpoint.pt").exists()


def test_nothing_the_browser_sends_becomes_a_path(studio):
    status, d = studio.request("POST", "/api/fits", {"input": {"text": "ok"}, "settings": FAST})
    job = d["job"]
    studio.events(job)
    for name in ("..%2Fjob.log", "..%2F..%2Fjobs.db", "%2Fetc%2Fpasswd", "nope.json"):
        status, body = studio.request("GET", f"/api/jobs/{job}/files/{name}")
        assert status == 404, name
    assert studio.request("GET", "/api/jobs/..%2F..%2Fx/result")[0] == 404
    assert studio.request("GET", "/api/jobs/0123/events")[0] == 404
    status, body = studio.request("POST", "/api/fits",
                                  {"input": {"upload": "/etc/passwd"}, "settings": {}})
    assert status == 400 and "upload is gone" in body["error"]
    status, body = studio.request("POST", "/api/fits",
                                  {"input": {"sample": "../../x"}, "settings": {}})
    assert status == 400 and "sample" in body["error"].lower()


def test_a_post_from_another_origin_or_not_json_is_refused(studio):
    body = {"input": {"text": "x"}, "settings": FAST}
    status, d = studio.request("POST", "/api/fits", body,
                               headers={"Origin": "http://evil.example"})
    assert status == 403 and "own page" in d["error"]
    status, d = studio.request("POST", "/api/fits", b"input=x",
                               headers={"Content-Type": "application/x-www-form-urlencoded"})
    assert status == 415


def test_a_studio_without_a_token_answers_only_to_its_loopback_names(studio):
    """DNS rebinding: a page at evil.example whose name was made to point at 127.0.0.1
    sends Host and Origin evil.example, which the same-origin rule passes; without a token
    the Host must be a loopback name. A malformed job id in the address is a 404."""
    body = {"input": {"text": "x"}, "settings": FAST}
    for host in ("evil.example", f"evil.example:{studio.port}", "127.0.0.1.evil.example"):
        status, d = studio.request("GET", "/api/jobs", headers={"Host": host})
        assert status == 403 and "answers only to localhost" in d["error"], host
        status, d = studio.request("POST", "/api/fits", body, headers={
            "Host": host, "Origin": f"http://{host}"})
        assert status == 403, host
    for host in (f"localhost:{studio.port}", f"127.0.0.1:{studio.port}", f"[::1]:{studio.port}"):
        assert studio.request("GET", "/api/jobs", headers={"Host": host})[0] == 200, host
    for bad in ("zzz", "096670D1" * 4):
        status, text = studio.request("GET", f"/job/{bad}")
        assert status == 404 and b"a job id is 32 hexadecimal digits" in text


def test_a_failed_fit_names_the_upload_not_the_server_s_folders(studio):
    svg = b'<svg xmlns="http://www.w3.org/2000/svg"><path d="M20 20 C 80 180, 120'
    status, d = studio.request("POST", "/api/uploads", svg, headers={"X-Filename": "bad.svg"})
    assert status == 200, d
    status, d = studio.request("POST", "/api/fits", {"input": {"upload": d["upload"]},
                                                     "settings": FAST})
    end = studio.events(d["job"])[-1]
    assert end["status"] == "failed" and end["error"].startswith("bad.svg: "), end
    assert str(studio.root) not in end["error"]


def test_a_word_the_font_cannot_write_is_refused_before_any_job(studio):
    before = studio.request("GET", "/api/jobs")[1]["jobs"]
    status, d = studio.request("POST", "/api/fits", {"input": {"text": "Café à Zoë"},
                                                     "settings": FAST})
    assert status == 400 and "has no glyph for 'éàë'" in d["error"], d
    assert studio.request("GET", "/api/jobs")[1]["jobs"] == before


def test_a_json_request_over_its_limit_is_refused_unread(studio):
    """A 300-MB JSON body took 1.45 GB of the studio's memory and started a fit."""
    pad = b'{"input": {"text": "hi"}, "settings": {}, "pad": "' + b"x" * (17 * 2**20) + b'"}'
    status, d = studio.request("POST", "/api/fits", pad,
                               headers={"Content-Type": "application/json"})
    assert status == 413 and "over 16 MB" in d["error"]


def test_off_loopback_an_empty_or_short_token_is_refused() -> None:
    for token in ("", "s3cret"):
        res = subprocess.run([sys.executable, "-m", "inkmotion", "studio", "--host", "0.0.0.0",
                              "--port", str(_free_port()), "--token", token, "--no-open"],
                             capture_output=True, text=True, timeout=60)
        assert res.returncode == 2, res.stderr
        assert "give one of 16 or more, or leave --token out" in res.stderr


def test_an_upload_is_checked_before_any_job(studio):
    status, d = studio.request("POST", "/api/uploads", b"not a png",
                               headers={"X-Filename": "scan.png"})
    assert status == 400 and d["error"].startswith("scan.png: its content is not a PNG")
    from inkmotion.samples import path_of

    data = Path(path_of("tempt-1")).read_bytes()
    status, d = studio.request("POST", "/api/uploads", data, headers={"X-Filename": "t 1.gml"})
    assert status == 200 and d["name"] == "t_1.gml"


def test_a_cancelled_fit_leaves_nothing(studio):
    job = studio.start_long_fit()
    assert studio.request("POST", f"/api/jobs/{job}/cancel", {})[1] == {"cancelled": True}
    assert studio.events(job)[-1]["status"] == "cancelled"
    assert studio.record(job).status == "cancelled"
    job_dir = studio.root / "jobs" / job
    assert not (job_dir / "artifacts").exists()
    assert not list(job_dir.glob("artifacts.*"))  # no staging folder left either
    assert studio.request("GET", f"/api/jobs/{job}/result")[0] == 409


def test_a_plan_sent_to_the_plotter_gives_g_code(studio):
    status, d = studio.request("POST", "/api/fits", {"input": {"text": "go"}, "settings": FAST})
    fit = d["job"]
    studio.events(fit)
    status, d = studio.request("POST", f"/api/jobs/{fit}/send",
                               {"kind": "plot", "paper": "A5", "machine": "marlin"})
    assert status == 200, d
    assert studio.events(d["job"])[-1]["status"] == "succeeded"
    status, r = studio.request("GET", f"/api/jobs/{d['job']}/result")
    assert r["figures"]["estimated_s"] > 0 and "plot.gcode" in r["files"]
    status, gcode = studio.request("GET", f"/api/jobs/{d['job']}/files/plot.gcode")
    assert b"G1" in gcode
    status, d = studio.request("POST", f"/api/jobs/{fit}/send", {"kind": "plot", "paper": "B9"})
    assert status == 400 and "paper is one of" in d["error"]
    status, d = studio.request("POST", f"/api/jobs/{fit}/send",
                               {"kind": "draw", "robot": "a b; rm -rf /", "dry_run": True})
    assert status == 400 and "robot's address" in d["error"]
    # a script that leaves dry_run out does not move an arm by default: it must say
    status, d = studio.request("POST", f"/api/jobs/{fit}/send",
                               {"kind": "draw", "robot": "127.0.0.1"})
    assert status == 400 and "dry_run" in d["error"], d
    status, d = studio.request("POST", f"/api/jobs/{fit}/send",  # no robot listens there
                               {"kind": "draw", "robot": "127.0.0.1", "dry_run": True})
    end = studio.events(d["job"])[-1]
    assert end["status"] == "failed" and "no FCI listens there" in end["error"], end
    status, d = studio.request("POST", f"/api/jobs/{fit}/send", {"kind": "simulate"})
    assert studio.events(d["job"])[-1]["status"] == "succeeded"
    status, r = studio.request("GET", f"/api/jobs/{d['job']}/result")
    assert "side_by_side.png" in r["files"]


def test_a_picture_uploaded_is_traced_and_fitted(studio):
    from urllib.parse import quote

    from inkmotion.samples import path_of

    data = Path(path_of("brush-scan")).read_bytes()
    # the page percent-encodes the name: a header is Latin-1, and スケッチ.png failed in it
    status, d = studio.request("POST", "/api/uploads", data,
                               headers={"X-Filename": quote("スケッチ scan.png")})
    assert status == 200 and d["name"] == "scan.png", d
    status, d = studio.request("POST", "/api/fits",
                               {"input": {"upload": d["upload"]}, "settings": FAST})
    assert studio.events(d["job"])[-1]["status"] == "succeeded"
    status, r = studio.request("GET", f"/api/jobs/{d['job']}/result")
    assert r["extraction"]["strokes"] >= 1 and r["paths"]


def test_a_recording_opens_in_rerun_s_web_viewer(studio):
    status, d = studio.request("POST", "/api/fits", {"input": {"text": "rr"}, "settings": FAST})
    job = d["job"]
    studio.events(job)
    status, d = studio.request("POST", f"/api/jobs/{job}/rerun", {})
    assert status == 200, d
    assert d["url"].startswith("http://127.0.0.1:") and "rerun%2Bhttp" in d["url"]
    with urllib.request.urlopen(d["url"], timeout=10) as r:
        assert r.status == 200 and b"<html" in r.read().lower()
    assert studio.request("POST", "/api/jobs/" + "0" * 32 + "/rerun", {})[0] == 404


def test_the_studio_s_rerun_viewer_sends_no_usage_statistics(tmp_path):
    """The viewer ran with RERUN_ANALYTICS=0, which the rerun binary never reads: its usage
    statistics were on (and its first run wrote the user's own ~/.config/rerun). Asked with
    the viewer's environment, the real binary now says they are off."""
    from inkmotion.recording import rerun_binary
    from inkmotion.studio.viewer import quiet_env

    binary = rerun_binary()
    if binary is None:
        pytest.skip("the rerun binary is not installed")
    res = subprocess.run([binary, "analytics", "config"], env=quiet_env(tmp_path),
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    config = json.loads(res.stdout[res.stdout.index("{"):])
    assert config["analytics_enabled"] is False
    assert config["config_file_path"].startswith(str(tmp_path))


def test_a_token_guards_a_studio_and_ctrl_c_ends_its_jobs_cleanly(tmp_path):
    s = Studio(tmp_path, "--token", "s3cret")
    try:
        status, d = s.request("GET", "/api/jobs")
        assert status == 401 and "token" in d["error"]
        with urllib.request.urlopen(s.url + "/?token=s3cret", timeout=10) as r:
            cookie = r.headers["set-cookie"]
        assert cookie.startswith("inkmotion_studio=s3cret") and "HttpOnly" in cookie
        s.headers = {"Cookie": "inkmotion_studio=s3cret"}
        status, d = s.request("GET", "/api/jobs")
        assert status == 200 and d == {"jobs": []}
        assert s.request("GET", "/api/jobs?token=wrong", headers={})[0] == 401
        job = s.start_long_fit()
    finally:
        s.stop()  # Ctrl-C
    assert s.proc.returncode is not None
    assert s.record(job).status == "cancelled"
    assert not (tmp_path / "jobs" / job / "artifacts").exists()
    assert not list((tmp_path / "jobs" / job).glob("artifacts.*"))


def test_ctrl_c_ends_a_studio_whose_page_follows_a_fit(tmp_path):
    """A page following a fit holds its event stream open: Ctrl-C waited for it (40 s,
    the job fitting on meanwhile). Now the page is closed after a few seconds and the job
    cancelled."""
    import signal
    import threading

    s = Studio(tmp_path)
    try:
        job = s.start_long_fit()
        follow = threading.Thread(target=lambda: s.events(job, timeout=120), daemon=True)
        follow.start()
        time.sleep(1.0)
        started = time.monotonic()
        os.kill(s.proc.pid, signal.SIGINT)
        s.proc.wait(20)
        took = time.monotonic() - started
    finally:
        s.stop()
    assert took < 15, took
    assert s.record(job).status == "cancelled"


@pytest.mark.services
def test_with_workers_a_fit_goes_through_the_queue(service_env, workers, tmp_path):
    s = Studio(tmp_path, "--workers", env=service_env)
    try:
        status, d = s.request("POST", "/api/fits", {"input": {"text": "q"}, "settings": FAST})
        assert status == 200, d
        events = s.events(d["job"], timeout=180)
        assert events[-1]["status"] == "succeeded", events[-1]
        record = s.record(d["job"])
        assert record.worker_host and record.worker_host != "" and record.status == "succeeded"
        status, r = s.request("GET", f"/api/jobs/{d['job']}/result")
        assert status == 200 and r["paths"]
    finally:
        s.stop()


@pytest.mark.services
def test_a_dead_studio_s_job_is_finished_by_a_worker(service_env, workers, tmp_path):
    import signal

    from service_fixtures import wait_for

    s = Studio(tmp_path, env=service_env)
    status, d = s.request("POST", "/api/fits", {"input": {"text": "lost"},
                                                "settings": {"steps": 200}})
    job = d["job"]
    with urllib.request.urlopen(f"{s.url}/api/jobs/{job}/events", timeout=120) as r:
        for line in r:  # past its first checkpoint (every 50 steps)
            if line.startswith(b"data: ") and json.loads(line[6:]).get("step", 0) >= 60:
                break
    os.killpg(s.proc.pid, signal.SIGKILL)  # the studio and its job processes, at once
    s.proc.wait()
    s.log.close()
    wait_for(lambda: s.record(job).status == "succeeded", 120)
    assert s.record(job).attempts == 2
    job_dir = Path(service_env["INKMOTION_DATA_DIR"]) / "jobs" / job
    report = json.loads((job_dir / "artifacts" / "report.json").read_text())
    assert report["resumed_from_step"] >= 50
    assert not (job_dir / "checkpoint.pt").exists()


def test_a_port_in_use_or_a_broker_down_is_one_sentence(studio):
    def run(*args: str, **env: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "inkmotion", "studio", "--no-open", *args],
                              env={**os.environ, **env}, capture_output=True, text=True,
                              timeout=120)

    busy = run("--port", str(studio.port))
    assert busy.returncode == 1
    assert busy.stderr.startswith(f"error: cannot listen on 127.0.0.1:{studio.port}")
    down = run("--port", "0", "--workers", INKMOTION_BROKER_URL="redis://127.0.0.1:1/0",
               INKMOTION_DATA_DIR=str(studio.root))
    assert down.returncode == 1 and "Cannot reach the broker" in down.stderr


def test_only_loopback_goes_without_a_token():
    from inkmotion.cli.studio import is_loopback

    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.5")


# -- the page in a real browser ----------------------------------------------------------------
@pytest.fixture(scope="module")
def browser():
    from inkmotion.browser import chromium, find_browser

    pytest.importorskip("selenium", reason="Selenium is not installed (the test extra)")
    if find_browser() is None:
        pytest.skip("Chromium and ChromeDriver are not installed (make test installs them)")
    with chromium(1300, 1000) as driver:
        yield driver


def _wait(driver, script: str, timeout: float = 120) -> object:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = driver.execute_script(script)
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for: {script}; status: "
                         + driver.execute_script("return document.getElementById('status')"
                                                 ".textContent + ' / ' + document."
                                                 "getElementById('message').textContent"))


def _set(driver, element_id: str, value: str) -> None:
    from selenium.webdriver.common.by import By

    field = driver.find_element(By.ID, element_id)
    field.clear()
    field.send_keys(value)


def test_a_drawing_made_with_pointer_events_is_fitted_and_animated(studio, browser):
    from selenium.webdriver.common.actions.action_builder import ActionBuilder
    from selenium.webdriver.common.actions.interaction import POINTER_PEN
    from selenium.webdriver.common.actions.pointer_input import PointerInput
    from selenium.webdriver.common.by import By

    browser.get(studio.url + "/")  # its timings: `inkmotion bench --only studio`
    pad = browser.find_element(By.ID, "pad")
    pen = PointerInput(POINTER_PEN, "pen")
    actions = ActionBuilder(browser, mouse=pen, duration=20)
    # an "L" and a separate bar, each stroke drawn in 20 ms steps
    for stroke in ([(-150, -100), (-150, 60), (-40, 60)], [(40, -100), (160, -60)]):
        actions.pointer_action.move_to(pad, *stroke[0]).pointer_down(pressure=0.6)
        for a, b in zip(stroke, stroke[1:], strict=False):
            for k in range(1, 11):
                x = a[0] + (b[0] - a[0]) * k / 10
                y = a[1] + (b[1] - a[1]) * k / 10
                actions.pointer_action.move_to(pad, int(x), int(y), pressure=0.6)
        actions.pointer_action.pointer_up()
    actions.perform()
    assert browser.execute_script("return window.studio.strokes.length") == 2
    _set(browser, "steps", "150")
    browser.find_element(By.ID, "fit").click()
    _wait(browser, "return window.studio.result")
    assert browser.execute_script("return window.studio.firstEventMs") > 0  # it was shown
    job = browser.execute_script("return window.studio.job")
    assert browser.current_url.endswith("/job/" + job)
    _wait(browser, "return window.studio.frames > 20")
    # the stored input: a GML tag whose times increase, fitted as well as a recorded one
    traces = read_gml(str(next((studio.root / "jobs" / job / "input").rglob("*.gml"))))
    assert len(traces.strokes) == 2
    assert all(np.all(np.diff(t) > 0) for t in traces.meta["t"])
    figures = browser.execute_script("return window.studio.result.figures")
    assert figures["chamfer_mean_px"] < 1.0 and figures["quality"] == "good", figures
    words = browser.find_element(By.ID, "figures").text
    assert "sub-movements" in words and "Chamfer" in words
    assert browser.find_element(By.ID, "recorded").is_displayed()  # it had times


def test_three_tabs_fit_at_once_each_its_own(studio, browser):
    from selenium.webdriver.common.by import By

    words = ["one", "two", "six"]
    handles = []
    for i, word in enumerate(words):
        if i:
            browser.switch_to.new_window("tab")
        browser.get(studio.url + "/")
        browser.find_element(By.ID, "tab-word").click()
        _set(browser, "word", word)
        _set(browser, "steps", "80")
        browser.find_element(By.ID, "fit").click()
        handles.append(browser.current_window_handle)
    labels = []
    for handle in handles:
        browser.switch_to.window(handle)
        _wait(browser, "return window.studio.result", 180)
        labels.append(browser.execute_script("return window.studio.result.label"))
    assert labels == [f"text:{w}" for w in words]
    for handle in handles[1:]:
        browser.switch_to.window(handle)
        browser.close()
    browser.switch_to.window(handles[0])


def test_a_bad_upload_is_refused_on_the_page(studio, browser, tmp_path):
    from selenium.webdriver.common.by import By

    fake = tmp_path / "scan.png"
    fake.write_text("this is not a picture")
    browser.get(studio.url + "/")
    before = studio.request("GET", "/api/jobs")[1]["jobs"]
    browser.find_element(By.ID, "tab-file").click()
    browser.find_element(By.ID, "file").send_keys(str(fake))
    message = _wait(browser, "return document.getElementById('message').textContent", 20)
    assert message.startswith("scan.png: its content is not a PNG picture")
    browser.find_element(By.ID, "fit").click()
    assert "Drop or pick a file first" in browser.find_element(By.ID, "message").text
    assert studio.request("GET", "/api/jobs")[1]["jobs"] == before


def test_cancel_on_the_page_and_a_closed_tab(studio, browser):
    from selenium.webdriver.common.by import By

    browser.get(studio.url + "/")
    browser.find_element(By.ID, "tab-sample").click()
    _set(browser, "steps", "4000")
    browser.find_element(By.ID, "fit").click()
    _wait(browser, "return document.getElementById('status').textContent"
                   ".startsWith('Fitting: step')", 60)
    job = browser.execute_script("return window.studio.job")
    browser.find_element(By.ID, "cancel").click()
    _wait(browser, "return document.getElementById('status').textContent"
                   ".startsWith('Cancelled')", 60)
    assert studio.record(job).status == "cancelled"
    assert not (studio.root / "jobs" / job / "artifacts").exists()
    # a tab closed mid-fit: the job goes on and ends complete
    browser.switch_to.new_window("tab")
    browser.get(studio.url + "/")
    browser.find_element(By.ID, "tab-word").click()
    _set(browser, "word", "bye")
    _set(browser, "steps", "80")
    browser.find_element(By.ID, "fit").click()
    _wait(browser, "return window.studio.job", 30)
    job = browser.execute_script("return window.studio.job")
    browser.close()
    browser.switch_to.window(browser.window_handles[0])
    deadline = time.monotonic() + 120
    while studio.record(job).status != "succeeded" and time.monotonic() < deadline:
        time.sleep(0.3)
    assert studio.record(job).status == "succeeded"
    assert (studio.root / "jobs" / job / "artifacts" / "plan.json").is_file()
    browser.get(studio.url + "/jobs")
    _wait(browser, f"return document.querySelector(\"tr[data-id='{job}']\")", 10)
