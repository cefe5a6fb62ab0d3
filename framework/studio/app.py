"""The studio's web app (Starlette on uvicorn): pages, the JSON API and the live stream.

Pages: ``/`` (draw, drop or pick a drawing; fit it; watch it move; send it on), ``/job/ID``
(the same page showing one job) and ``/jobs`` (the job store). The API under ``/api``:

========================================  ================================================
``POST /api/uploads``                     the file as the body, its name in ``X-Filename``:
                                          checked (:mod:`.uploads`), kept for a fit
``POST /api/fits``                        ``{"input": {...}, "settings": {...}}``: a fit job
``GET  /api/status``                      ready (job processes warmed up), slots, workers
``GET  /api/jobs``                        the jobs, newest first
``GET  /api/jobs/ID/events``              server-sent events of the job (:mod:`.runner`)
``POST /api/jobs/ID/cancel``              cancel it
``GET  /api/jobs/ID/result``              the motion and figures (:mod:`.motion`)
``GET  /api/jobs/ID/files/NAME``          one of its artifacts (a download)
``POST /api/jobs/ID/send``                ``{"kind": "plot"|"simulate"|"draw", ...}``: a job
                                          of that kind on the fit's plan.json
``POST /api/jobs/ID/rerun``               its recording in rerun's web viewer (:mod:`.viewer`)
========================================  ================================================

Safety: every error the user caused is a 4xx with ``{"error": one sentence}``; job ids are
matched against the store's form and file names against the artifacts' own listing, so
nothing the browser sends becomes a path; pages are Jinja2 with autoescape; a POST must be
JSON (or the upload's octet stream) from this page's own origin; and with a token
(``inkmotion studio --host`` on a non-loopback address) every request must carry it.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
import secrets
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jinja2
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import (
    FileResponse,
    JSONResponse,
    PlainTextResponse,
    Response,
    StreamingResponse,
)
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles
from starlette.templating import Jinja2Templates

from inkmotion.errors import InkmotionError
from inkmotion.jobs.spec import JobSpec
from inkmotion.settings import Settings
from inkmotion.studio.runner import Runner, artifacts_of
from inkmotion.studio.viewer import RerunViewer

HERE = Path(__file__).parent
TOKEN_COOKIE = "inkmotion_studio"
_JOB_ID = re.compile(r"[0-9a-f]{32}")
_WORD = re.compile(r"[\w' .,!?&-]{1,40}")
#: the settings a page may give a fit: name -> (type, low, high); anything else is refused
FIT_SETTINGS: dict[str, tuple[type, float, float]] = {
    "steps": (int, 20, 5000), "size": (int, 100, 2000), "lambda_smooth": (float, 0, 1000),
    "tolerance": (float, 0, 50), "varying_width": (bool, 0, 1), "invert": (bool, 0, 1),
}
#: the kinds a fit's plan can be sent to, and the settings each takes from the page
SEND_KINDS: dict[str, tuple[str, ...]] = {
    "plot": ("paper", "machine", "orientation", "margin"),
    "simulate": (), "draw": ("robot", "dry_run"),
}
_HOST = re.compile(r"[A-Za-z0-9.:-]{1,253}")
SEND_CHOICES = {"paper": ("A5", "A4", "A3", "letter"), "machine": ("grbl", "marlin", "klipper"),
                "orientation": ("auto", "portrait", "landscape")}


class UserError(Exception):
    """A request the user must change: HTTP ``status`` with one sentence."""

    def __init__(self, message: str, status: int = 400) -> None:
        super().__init__(message)
        self.status = status


@dataclass
class Studio:
    """What the routes share: settings, the job runner, the token, the kept uploads."""

    settings: Settings
    runner: Runner
    token: str | None = None
    uploads: dict[str, Path] = field(default_factory=dict)
    viewer: RerunViewer = field(default_factory=RerunViewer)

    @property
    def upload_dir(self) -> Path:
        return self.settings.data_dir / "studio-uploads"


def create_app(settings: Settings, *, token: str | None = None, workers: bool = False,
               slots: int | None = None) -> Starlette:
    """The studio app over ``settings``' data directory and job store; ``token``: a
    secret every request must carry (``?token=`` once, then a cookie); ``workers``: jobs
    are queued for the workers instead of running in this process."""
    studio = Studio(settings, Runner(settings, workers=workers, slots=slots), token)
    templates = Jinja2Templates(env=jinja2.Environment(
        loader=jinja2.FileSystemLoader(HERE / "templates"), autoescape=True))
    routes = [
        Route("/", _page(studio, templates, "studio.html.j2")),
        Route("/job/{job_id}", _page(studio, templates, "studio.html.j2")),
        Route("/jobs", _page(studio, templates, "jobs.html.j2")),
        Route("/api/uploads", _api(studio, upload), methods=["POST"]),
        Route("/api/fits", _api(studio, start_fit), methods=["POST"]),
        Route("/api/status", _api(studio, status)),
        Route("/api/jobs", _api(studio, list_jobs)),
        Route("/api/jobs/{job_id}/events", _api(studio, events)),
        Route("/api/jobs/{job_id}/cancel", _api(studio, cancel), methods=["POST"]),
        Route("/api/jobs/{job_id}/result", _api(studio, result)),
        Route("/api/jobs/{job_id}/files/{name}", _api(studio, download)),
        Route("/api/jobs/{job_id}/send", _api(studio, send), methods=["POST"]),
        Route("/api/jobs/{job_id}/rerun", _api(studio, rerun_viewer), methods=["POST"]),
        Mount("/static", StaticFiles(directory=str(HERE / "static")), name="static"),
    ]

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> Any:
        threading.Thread(target=_warm_up, args=(settings.db_url,), name="studio-warm-up",
                         daemon=True).start()
        yield
        studio.viewer.close()
        await asyncio.to_thread(studio.runner.close)  # stops what runs here, cleanly

    app = Starlette(routes=routes, lifespan=lifespan)
    app.state.studio = studio
    return _guarded(app, studio)


def _warm_up(db_url: str) -> None:
    """What this process does at a page's first Fit and first result, done at start: the
    spec's checks (the plugins, the kinds), the job store's engine and the motion's
    sampling (torch)."""
    from inkmotion.jobs.kind import resolve
    from inkmotion.store import list_jobs
    from inkmotion.studio.motion import warm_up

    resolve(JobSpec(kind="fit", inputs={"drawing": "text:a"}))
    list_jobs(limit=1, db_url=db_url)
    warm_up()


# -- guards ---------------------------------------------------------------------------------
def _guarded(app: Any, studio: Studio) -> Any:
    """``app`` behind the token (when there is one) and the same-origin rule for POSTs."""

    async def guard(scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            return await app(scope, receive, send)
        request = Request(scope)
        refusal = _refusal(request, studio.token)
        if refusal is not None:
            return await JSONResponse({"error": refusal[1]}, refusal[0])(scope, receive, send)
        given = request.query_params.get("token")
        if studio.token and given and request.method == "GET":
            # the printed address carries the token once; the cookie carries it afterwards
            async def with_cookie(message: dict) -> None:
                if message["type"] == "http.response.start":
                    cookie = (f"{TOKEN_COOKIE}={studio.token}; HttpOnly; SameSite=Strict; "
                              "Path=/")
                    message.setdefault("headers", []).append((b"set-cookie", cookie.encode()))
                await send(message)

            return await app(scope, receive, with_cookie)
        return await app(scope, receive, send)

    return guard


#: the largest JSON request the studio reads (a drawing made on the page is a few hundred
#: KB; a file goes as an upload, under its own limit)
MAX_JSON_BYTES = 16 * 2**20
#: the names a studio without a token answers to (its loopback address as a browser on the
#: same machine writes it)
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")


def _refusal(request: Request, token: str | None) -> tuple[int, str] | None:
    if not token and _host_name(request.headers.get("host", "")) not in LOOPBACK_NAMES:
        # a page elsewhere whose name was made to point at 127.0.0.1 (DNS rebinding) sends
        # its own name as Host, and its own origin, which the POST rule below would pass
        return 403, ("This studio answers only to localhost or 127.0.0.1 (run it with "
                     "--host to serve it elsewhere, with its token).")
    if token:
        given = request.query_params.get("token") or request.cookies.get(TOKEN_COOKIE) or ""
        if not secrets.compare_digest(given.encode(), token.encode()):
            return 401, ("This studio needs its token: open the address that "
                         "`inkmotion studio` printed (it ends in ?token=...).")
    if request.method == "POST":
        origin = request.headers.get("origin")
        host = request.headers.get("host", "")
        if origin is not None and origin.split("://", 1)[-1] != host:
            return 403, "Requests must come from the studio's own page."
        kind = request.headers.get("content-type", "").split(";")[0].strip()
        if kind not in ("application/json", "application/octet-stream"):
            return 415, "The studio takes JSON or a file's bytes; use its page."
    return None


def _host_name(host: str) -> str:
    """The name in a Host header, without its port ('[::1]:8765' -> '::1')."""
    from urllib.parse import urlsplit

    try:
        return urlsplit(f"//{host}").hostname or ""
    except ValueError:
        return ""


def _api(studio: Studio, handler: Any) -> Any:
    """A route calling ``handler(studio, request)``; a :class:`UserError` or an
    :class:`InkmotionError` becomes a 4xx with its one sentence."""

    async def endpoint(request: Request) -> Response:
        try:
            return await handler(studio, request)
        except UserError as exc:
            return JSONResponse({"error": str(exc)}, exc.status)
        except InkmotionError as exc:
            return JSONResponse({"error": str(exc)}, 400)

    return endpoint


def _page(studio: Studio, templates: Jinja2Templates, name: str) -> Any:
    async def endpoint(request: Request) -> Response:
        job_id = request.path_params.get("job_id")
        if job_id is not None:
            try:
                job_id = _job_id(job_id)
            except UserError as exc:
                return PlainTextResponse(str(exc), exc.status)
        return templates.TemplateResponse(request, name, _context(studio, job_id))

    return endpoint


def _context(studio: Studio, job_id: str | None) -> dict[str, Any]:
    from inkmotion.kinds.fit import FitParams
    from inkmotion.plugin_host import host
    from inkmotion.samples import available
    from inkmotion.studio.uploads import accepted

    defaults = FitParams.__dataclass_fields__
    fit = {name: defaults[name].default for name in FIT_SETTINGS}
    renderers = sorted(host().plugins("renderer"))
    samples = [{"name": s.name, "description": s.description} for s in available()
               if "fit" in s.kinds]
    return {"job_id": job_id, "defaults": fit, "renderers": renderers, "samples": samples,
            "accept": accepted(), "workers": studio.runner.workers,
            "send_choices": SEND_CHOICES,
            # JSON inside <script>: no "<" can close the element early
            "config": json.dumps({"job": job_id, "defaults": fit}).replace("<", "\\u003c")}


def _job_id(text: str) -> str:
    if not _JOB_ID.fullmatch(text):
        raise UserError("No such job: a job id is 32 hexadecimal digits.", 404)
    return text


async def _body(request: Request, limit: int) -> bytes:
    """The request's body, read no further than past ``limit`` bytes (longer than it: the
    caller refuses it, a huge body never held whole)."""
    data = bytearray()
    async for chunk in request.stream():
        data += chunk
        if len(data) > limit:
            break
    return bytes(data)


async def _json_body(request: Request) -> dict[str, Any]:
    raw = await _body(request, MAX_JSON_BYTES)
    if len(raw) > MAX_JSON_BYTES:
        raise UserError(f"The request is over {MAX_JSON_BYTES // 2**20} MB, more than any "
                        "drawing or setting needs; use the studio's page.", 413)
    try:
        body = json.loads(raw)
    except ValueError:
        raise UserError("The request is not JSON; use the studio's page.") from None
    if not isinstance(body, dict):
        raise UserError("The request is not a JSON object; use the studio's page.")
    return body


# -- inputs and fits ------------------------------------------------------------------------
async def upload(studio: Studio, request: Request) -> Response:
    from urllib.parse import unquote

    from inkmotion.studio.uploads import check_upload, store_upload

    # percent-encoded by the page: a header carries Latin-1 only (スケッチ.png failed)
    filename = unquote(request.headers.get("x-filename", ""))
    limit = studio.settings.max_input_bytes
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > limit:
        raise UserError(f"{filename or 'The upload'}: {int(declared) / 2**20:.1f} MB is above "
                        f"the {limit / 2**20:.0f} MB upload limit; send a smaller file.", 413)
    data = await _body(request, limit)
    name = await asyncio.to_thread(check_upload, filename, data, limit)
    path = await asyncio.to_thread(store_upload, studio.upload_dir, name, data)
    key = secrets.token_hex(16)
    studio.uploads[key] = path
    return JSONResponse({"upload": key, "name": name, "bytes": len(data)})


def fit_spec(studio: Studio, body: dict[str, Any]) -> JobSpec:
    """The fit's spec from the page's ``{"input": {...}, "settings": {...}}``."""
    given = body.get("input")
    if not isinstance(given, dict) or len(given) != 1:
        raise UserError("Give one input: a sample, a word, a drawing or an uploaded file.")
    (form, value), = given.items()
    if form == "sample":
        from inkmotion.samples import find

        source = "sample:" + find(str(value)).name
    elif form == "text":
        word = str(value).strip()
        if not _WORD.fullmatch(word):
            raise UserError("Type a word of 1 to 40 letters, digits or simple punctuation.")
        from inkmotion.inputs.hershey import render_text

        render_text(word)  # a letter the font lacks (é) is said now, not by a failed job
        source = "text:" + word
    elif form == "upload":
        path = studio.uploads.get(str(value))
        if path is None or not path.is_file():
            raise UserError("That upload is gone (the studio restarted); drop the file again.")
        source = str(path)
    elif form == "drawing":
        from inkmotion.studio.drawing import drawing_gml
        from inkmotion.studio.uploads import store_upload

        source = str(store_upload(studio.upload_dir, "drawing.gml",
                                  drawing_gml(value).encode()))
    else:
        raise UserError(f"Unknown input {form!r}; give a sample, text, drawing or upload.")
    return JobSpec(kind="fit", inputs={"drawing": source},
                   params=fit_params(body.get("settings") or {}))


def fit_params(settings: Any) -> dict[str, Any]:
    """The fit parameters a page chose, each checked against :data:`FIT_SETTINGS` (and
    ``targets``, ``renderer``); one sentence for the first that is wrong."""
    if not isinstance(settings, dict):
        raise UserError("The settings are not a JSON object; use the studio's page.")
    params: dict[str, Any] = {}
    for name, value in settings.items():
        if name == "targets":
            text = str(value).strip()
            if text not in ("default", "auto") and not (text.isdigit() and 1 <= int(text) <= 500):
                raise UserError("Targets are 'default', 'auto' or a number from 1 to 500.")
            params[name] = text
        elif name == "renderer":
            params[name] = {"name": str(value)}  # checked against the plugins by the spec
        elif name in FIT_SETTINGS:
            kind, low, high = FIT_SETTINGS[name]
            params[name] = _setting(name, value, kind, low, high)
        else:
            raise UserError(f"Unknown setting {name!r}; the page gives only its own.")
    return params


def _setting(name: str, value: Any, kind: type, low: float, high: float) -> Any:
    if kind is bool:
        if not isinstance(value, bool):
            raise UserError(f"{name} is on or off.")
        return value
    try:
        number = kind(value)
    except (TypeError, ValueError):
        raise UserError(f"{name} must be a number from {low:g} to {high:g}.") from None
    if not low <= number <= high:  # NaN fails this too
        raise UserError(f"{name} must be a number from {low:g} to {high:g}.")
    return number


async def start_fit(studio: Studio, request: Request) -> Response:
    spec = fit_spec(studio, await _json_body(request))
    job_id = await asyncio.to_thread(studio.runner.start, spec)
    return JSONResponse({"job": job_id})


async def send(studio: Studio, request: Request) -> Response:
    """A plot, simulate or draw job on the fit's plan.json."""
    job_id = _job_id(request.path_params["job_id"])
    body = await _json_body(request)
    kind = str(body.get("kind"))
    if kind not in SEND_KINDS:
        raise UserError(f"A plan is sent to {', '.join(SEND_KINDS)}; not {kind!r}.")
    if kind == "draw" and "dry_run" not in body:  # the page always says; a script must too
        raise UserError("A draw moves a real arm: say whether it is a dry run, "
                        '"dry_run": true (connect and check only) or false (draw).')
    plan = artifacts_of(studio.settings, job_id) / "plan.json"
    if not plan.is_file():
        raise UserError("This job has no finished plan yet; wait for the fit to end.", 409)
    params = {}
    for name in SEND_KINDS[kind]:
        if name in body:
            params[name] = _send_setting(name, body[name])
    spec = JobSpec(kind=kind, inputs={"plan": str(plan)}, params=params)
    new = await asyncio.to_thread(studio.runner.start, spec)
    return JSONResponse({"job": new, "kind": kind})


def _send_setting(name: str, value: Any) -> Any:
    """One setting of a plot or draw job from the page, checked."""
    if name == "margin":
        return _setting(name, value, float, 0, 100)
    if name == "dry_run":
        return _setting(name, value, bool, 0, 1)
    text = str(value).strip()
    if name in SEND_CHOICES and text not in SEND_CHOICES[name]:
        raise UserError(f"{name} is one of {', '.join(SEND_CHOICES[name])}.")
    if name == "robot" and not _HOST.fullmatch(text):
        raise UserError("Give the robot's address: the FCI's hostname or IP, e.g. "
                        "172.16.0.2.")
    return text


# -- following jobs -------------------------------------------------------------------------
async def status(studio: Studio, request: Request) -> Response:
    runner = studio.runner
    return JSONResponse({"ready": runner.ready, "slots": runner.slots,
                         "workers": runner.workers})


async def list_jobs(studio: Studio, request: Request) -> Response:
    from inkmotion import store

    records = await asyncio.to_thread(store.list_jobs, None, 100, studio.settings.db_url)
    return JSONResponse({"jobs": [_row(r) for r in records]})


def _label(text: str) -> str:
    """A job's input as the jobs page names it: a word or sample as given, a file by its
    name, another job's plan as "plan of <its id>"."""
    path = Path(text)
    if path.name == "plan.json" and path.parent.name == "artifacts":
        return f"plan of {path.parent.parent.name[:8]}"
    return path.name if "/" in text else text


def _row(record: Any) -> dict[str, Any]:
    return {"id": record.id, "kind": record.kind, "status": record.status,
            "label": _label(record.label),
            "step": record.step, "total": record.total, "error": record.error,
            "created": record.created_at.strftime("%Y-%m-%d %H:%M:%S UTC"),
            "metrics": {k: v for k, v in (record.metrics or {}).items()
                        if isinstance(v, int | float | str)}}


async def events(studio: Studio, request: Request) -> Response:
    job_id = _job_id(request.path_params["job_id"])
    runner = studio.runner

    async def stream() -> Any:
        index, idle = 0, 0.0
        yield "retry: 1000\n\n"
        while True:
            batch, index, ended = await asyncio.to_thread(runner.events, job_id, index)
            for event in batch:
                yield f"data: {json.dumps(event)}\n\n"
            if ended or any(e.get("type") == "end" for e in batch):
                return
            if await request.is_disconnected():
                return  # the tab closed: the job goes on, and is listed
            idle = 0.0 if batch else idle + 0.1
            if idle >= 10:
                yield ": alive\n\n"
                idle = 0.0
            await asyncio.sleep(0.1 if runner.live(job_id) is not None else 0.5)

    return StreamingResponse(stream(), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache"})


async def cancel(studio: Studio, request: Request) -> Response:
    job_id = _job_id(request.path_params["job_id"])
    done = await asyncio.to_thread(studio.runner.cancel, job_id)
    return JSONResponse({"cancelled": bool(done)})


async def result(studio: Studio, request: Request) -> Response:
    from inkmotion import store
    from inkmotion.studio.motion import motion_payload

    job_id = _job_id(request.path_params["job_id"])
    record = await asyncio.to_thread(store.get_job, job_id, studio.settings.db_url)
    if record is None:
        raise UserError("No such job in the job store.", 404)
    if record.status != "succeeded":
        raise UserError(f"This job is {record.status}; its result is not there.", 409)
    payload = await asyncio.to_thread(motion_payload, artifacts_of(studio.settings, job_id))
    payload.update(job=job_id, status=record.status, label=_row(record)["label"],
                   spec_kind=record.kind)
    return JSONResponse(payload)


async def download(studio: Studio, request: Request) -> Response:
    job_id = _job_id(request.path_params["job_id"])
    folder = artifacts_of(studio.settings, job_id)
    name = request.path_params["name"]
    files = {p.name: p for p in folder.iterdir() if p.is_file()} if folder.is_dir() else {}
    if name not in files:  # the artifacts' own names only: nothing sent becomes a path
        raise UserError(f"This job has no file {name[:60]!r}.", 404)
    inline = request.query_params.get("inline") == "1"
    return FileResponse(files[name], filename=None if inline else f"{job_id[:8]}-{name}",
                        content_disposition_type="inline" if inline else "attachment")


async def rerun_viewer(studio: Studio, request: Request) -> Response:
    """The job's recording.rrd served by rerun's web viewer; its address."""
    from inkmotion.recording import RECORDING_NAME

    job_id = _job_id(request.path_params["job_id"])
    recording = artifacts_of(studio.settings, job_id) / RECORDING_NAME
    if not recording.is_file():
        raise UserError("This job has no rerun recording (yet).", 404)
    url = await asyncio.to_thread(studio.viewer.open, recording)
    return JSONResponse({"url": url})
