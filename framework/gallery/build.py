"""Build the static gallery: an index of cards and a page per job (Jinja2 templates).

Layout of the site (every link relative, so it works from ``file://`` and behind any
static server; no external resource)::

    index.html                 the cards, with filters by kind and status and a search
    static/                    gallery.css, gallery.js (copied from the templates folder)
    jobs/<id>/index.html       a job's page
    jobs/<id>/thumb.png        its card's thumbnail
    jobs/<id>/files/           its artifacts, to view and download (hard links where the
                               file system allows, else copies: artifacts never change
                               in place, a job that runs again writes new files)
    manifest.json              what was built from what: the incremental build's memory

The build is incremental: a job's page is rebuilt only when its fingerprint
(:meth:`Entry.fingerprint`: its figures, status and files) changed, or when the templates
or the inkmotion version did; pages of jobs that are gone are removed; the index is always
rewritten. Each job's folder is staged and renamed into place, and the index and manifest
are written atomically, so an interrupted build leaves the previous complete site.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import shlex
import shutil
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from inkmotion.errors import SpecError
from inkmotion.gallery import summary
from inkmotion.gallery.entries import CARD_METRICS, DOWNLOADS, FIGURES, Entry
from inkmotion.gallery.relations import Relations, relate

MANIFEST = "manifest.json"
THUMB_WIDTH = 360  # px, the card's thumbnail (twice its CSS width for sharp screens)
ASSETS = "inkmotion.gallery_assets"  # the gallery/ folder: templates/ and static/
WIDE_FIGURES = frozenset({"speed.png", "speeds.png", "human_speeds.png", "side_by_side.png",
                          "feed.png"})


@dataclass
class BuildReport:
    """What a build did."""

    out: Path
    jobs: int = 0
    built: list[str] = field(default_factory=list)
    unchanged: int = 0
    removed: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def index(self) -> Path:
        return self.out / "index.html"


def assets_dir() -> Path:
    """The installed gallery/ folder (templates/ and static/)."""
    return Path(str(resources.files(ASSETS)))


def _environment(templates: Path | None) -> Any:
    import jinja2

    folders = [str(templates)] if templates is not None else []
    folders.append(str(assets_dir() / "templates"))
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(folders),
                             autoescape=jinja2.select_autoescape(["html", "j2"]),
                             undefined=jinja2.StrictUndefined, trim_blocks=True,
                             lstrip_blocks=True, keep_trailing_newline=True)
    env.filters.update(show=summary.show, duration=summary.duration, size=summary.size)
    return env


def _site_hash(templates: Path | None) -> str:
    """Changes when a template, a static file, the gallery's own code (what a page shows
    of a job) or the inkmotion version does."""
    import inkmotion

    h = hashlib.sha256(inkmotion.__version__.encode())
    sources = [(assets_dir() / "templates", "*"), (assets_dir() / "static", "*"),
               (Path(__file__).parent, "*.py"), *([(templates, "*")] if templates else [])]
    for folder, pattern in sources:
        for p in sorted(folder.rglob(pattern)):
            if p.is_file() and "__pycache__" not in p.parts:
                h.update(p.name.encode())
                h.update(p.read_bytes())
    return h.hexdigest()[:20]


def check_out_dir(out: Path) -> dict[str, Any]:
    """The previous manifest of the gallery at ``out`` (``{}`` for a new or empty folder);
    refuses a file, or a folder holding something else, naming it."""
    if out.exists() and not out.is_dir():
        raise SpecError(f"--out {out} is a file; give a folder for the gallery.")
    if not out.exists() or not any(out.iterdir()):
        return {}
    manifest = out / MANIFEST
    try:
        value = json.loads(manifest.read_text())
        if isinstance(value, dict) and value.get("generator") == "inkmotion gallery":
            return value
    except (OSError, json.JSONDecodeError):
        pass
    raise SpecError(f"--out {out} holds files that are not an inkmotion gallery (no readable "
                    f"{MANIFEST}); give a new or empty folder, so nothing of yours is "
                    "overwritten.")


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def _link_or_copy(src: Path, dst: Path) -> None:
    try:
        os.link(src, dst)
    except OSError:  # another file system, or links not allowed: copy
        shutil.copy2(src, dst)


def _thumbnail(src: Path, dst: Path) -> bool:
    """A ``THUMB_WIDTH``-wide PNG of ``src`` on white (False: unreadable image)."""
    import cv2
    import numpy as np

    image = cv2.imread(str(src), cv2.IMREAD_UNCHANGED)
    if image is None:
        return False
    if image.ndim == 3 and image.shape[2] == 4:  # flatten transparency onto white
        alpha = image[:, :, 3:4].astype(np.float32) / 255.0
        image = (image[:, :, :3] * alpha + 255.0 * (1 - alpha)).astype(np.uint8)
    h, w = image.shape[:2]
    if w > THUMB_WIDTH:
        image = cv2.resize(image, (THUMB_WIDTH, max(1, round(h * THUMB_WIDTH / w))),
                           interpolation=cv2.INTER_AREA)
    return bool(cv2.imwrite(str(dst), image))


def _csv_table(path: Path) -> tuple[list[str], list[list[str]]] | None:
    """Header and rows of a CSV artifact (None when unreadable), numbers to 3 digits."""
    try:
        with path.open(newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error):
        return None
    if not rows:
        return None

    def cell(text: str) -> str:
        try:
            return summary.show(float(text)) if text.strip() else text
        except ValueError:
            return text

    header = [summary.EVALUATION_COLUMNS.get(h, h) for h in rows[0]]
    return header, [[cell(c) for c in row] for row in rows[1:]]


def _commands(entry: Entry, page_dir: Path) -> dict[str, str]:
    """The commands that reproduce and replay the job, with absolute paths (``page_dir``:
    where the job's page will be)."""
    commands: dict[str, str] = {}
    config = entry.job_json if entry.job_json is not None else page_dir / "files" / "spec.json"
    if entry.job_json is not None or entry.writes_spec:
        again = (f"{entry.artifacts.name}-again" if entry.source == "folder" and entry.artifacts
                 else entry.id[:8])
        commands["reproduce"] = (f"inkmotion run --config {_quote(config)} "
                                 f"--out results/{again}")
    if "recording.rrd" in entry.files and entry.artifacts is not None:
        target = entry.id if entry.source == "store" else str(entry.artifacts / "recording.rrd")
        commands["replay"] = f"inkmotion view {_quote(target)}"
    return commands


def _quote(value: Any) -> str:
    return shlex.quote(str(value))


def _figures(entry: Entry) -> list[tuple[str, str]]:
    known = dict(FIGURES)
    shown = [(name, caption) for name, caption in FIGURES if name in entry.files]
    shown += [(n, n) for n in entry.files if n.endswith((".png", ".jpg")) and n not in known]
    if "drawing.svg" in entry.files:  # the vector drawing stands for its PNG
        shown = [("drawing.svg", "The drawing (SVG)")] + [f for f in shown
                                                          if f[0] != "drawing.png"]
    return shown


def _downloads(entry: Entry, files_dir: Path) -> list[tuple[str, str]]:
    names = [n for n in DOWNLOADS if n in entry.files]
    names += [n for n in entry.files if n not in names]
    return [(n, summary.size((files_dir / n).stat().st_size)) for n in names]


def _card(entry: Entry, thumb: bool, params: list[tuple[str, str]]) -> dict[str, Any]:
    """What the index needs of a job (kept in the manifest, so an unchanged job's card is
    drawn without reading its files again); ``params``: its key parameters."""
    names = [k for k in CARD_METRICS.get(entry.kind, ()) if k in entry.metrics]
    if not names:  # another kind (a plugin's): its own first three figures
        names = [k for k, v in entry.metrics.items()
                 if isinstance(v, (int, float)) and not isinstance(v, bool)][:3]
    metrics = [summary.figure(k, entry.metrics[k], entry.kind) for k in names]
    poor = entry.metrics.get("quality") == "poor"
    random_weights = entry.report.get("clip_weights") == "random"
    search = " ".join([entry.id, entry.kind, entry.status, entry.label, *(["poor"] * poor),
                       *(["random-weights"] * random_weights),
                       *(f"{k}={v}" for k, v in params)]).lower()
    return {"id": entry.id, "kind": entry.kind, "status": entry.status, "label": entry.label,
            "title": summary.short_label(entry.label),
            "created": entry.created.isoformat(timespec="seconds") if entry.created else "",
            "created_shown": entry.created.strftime("%Y-%m-%d %H:%M") if entry.created else "",
            "duration": summary.duration(entry.duration_s),
            "metrics": metrics, "params": params[:6], "more_params": max(0, len(params) - 6),
            "thumb": f"jobs/{entry.id}/thumb.png" if thumb else None,
            "progress": list(entry.progress) if entry.progress else None,
            "error": (entry.error or "").strip().splitlines()[0][:160] if entry.error else None,
            "problem": entry.problem, "search": search,
            "poor": poor, "random_weights": random_weights}


def _link(entry: Entry) -> dict[str, Any]:
    """Another job as a page links to it."""
    return {"id": entry.id, "kind": entry.kind, "title": summary.short_label(entry.label),
            "href": f"../{entry.id}/index.html"}


def _related(entry: Entry, relations: Relations, by_id: dict[str, Entry]) -> dict[str, Any]:
    """What the page shows of the jobs made from this job's plan (a simulated drawing, an
    evaluation table) and a link to the job whose plan it used."""
    made_from = relations.made_from.get(entry.id)
    used_by = []
    for other in (by_id[i] for i in relations.used_by.get(entry.id, [])):
        item = _link(other)
        figure = "sim_drawing.png" if "sim_drawing.png" in other.files else other.thumbnail
        item["figure"] = f"../{other.id}/files/{figure}" if figure else None
        item["evaluation"] = (_csv_table(other.artifacts / "evaluation.csv")
                              if other.artifacts and "evaluation.csv" in other.files else None)
        used_by.append(item)
    return {"made_from": _link(by_id[made_from]) if made_from else None, "used_by": used_by}


def _build_job(entry: Entry, out: Path, env: Any,
               related: dict[str, Any]) -> dict[str, Any]:
    """Stage and commit ``jobs/<id>/``; return the job's card."""
    from inkmotion.outputs.atomic import StagingDir

    final = out / "jobs" / entry.id
    with StagingDir(final) as stage:
        assert stage.path is not None
        files_dir = stage.path / "files"
        files_dir.mkdir()
        for name in entry.files:
            _link_or_copy(entry.artifacts / name, files_dir / name)  # type: ignore[operator]
        if entry.writes_spec:
            (files_dir / "spec.json").write_text(json.dumps(entry.spec, indent=1))
        thumb = entry.thumbnail
        has_thumb = bool(thumb) and _thumbnail(files_dir / thumb, stage.path / "thumb.png")
        key_params = summary.key_parameters(entry.kind, entry.params)
        card = _card(entry, has_thumb, key_params)
        evaluation = (_csv_table(files_dir / "evaluation.csv")
                      if "evaluation.csv" in entry.files else None)
        page = env.get_template("job.html.j2").render(
            root="../../", card=card, entry=entry,
            figures=_figures(entry), downloads=_downloads(entry, files_dir),
            commands=_commands(entry, final),
            evaluation=evaluation, related=related,
            metrics=[summary.figure(k, v, entry.kind) for k, v in entry.metrics.items()],
            params=summary.parameter_rows(entry.kind, entry.params),
            changed={k for k, _ in key_params},
            wide=WIDE_FIGURES,
            stages=entry.report.get("stages") if isinstance(entry.report.get("stages"), list)
            else None,
            warnings=[str(w) for w in entry.report.get("warnings") or []
                      if isinstance(entry.report.get("warnings"), list)],
            report=[summary.figure(k, v, entry.kind) for k, v in entry.report.items()
                    if isinstance(v, (int, float, str, bool)) and k not in entry.metrics])
        (stage.path / "index.html").write_text(page, encoding="utf-8")
    return card


def build_gallery(entries: Iterable[Entry], out: str | Path, *,
                  templates: str | Path | None = None, full: bool = False,
                  title: str = "inkmotion gallery",
                  on_job: Callable[[Entry, bool], None] | None = None) -> BuildReport:
    """Build (or update) the gallery of ``entries`` in ``out``; see the module docstring.

    ``templates``: a folder whose templates replace the built-in ones of the same name;
    ``full``: rebuild every page; ``on_job(entry, rebuilt)`` is called after each job (a
    progress bar). Raises :class:`SpecError` for an ``out`` that is not a gallery.
    """
    started = time.perf_counter()
    out = Path(out).resolve()
    templates = Path(templates).resolve() if templates is not None else None
    if templates is not None and not templates.is_dir():
        raise SpecError(f"--templates {templates} is not a folder; give the folder that "
                        "holds your index.html.j2 / job.html.j2.")
    previous = check_out_dir(out)
    env = _environment(templates)
    site = _site_hash(templates)
    known: dict[str, Any] = previous.get("jobs", {}) if previous.get("site") == site and \
        not full else {}
    (out / "jobs").mkdir(parents=True, exist_ok=True)
    static = out / "static"
    if previous.get("site") != site or not static.is_dir():  # new templates or static files
        shutil.rmtree(static, ignore_errors=True)
        shutil.copytree(assets_dir() / "static", static)

    report = BuildReport(out=out)
    cards: list[dict[str, Any]] = []
    jobs: dict[str, Any] = {}
    entries = list(entries)
    by_id = {e.id: e for e in entries}
    relations = relate(entries)
    own = {e.id: e.fingerprint() for e in entries}
    for entry in entries:
        # a page shows something of its related jobs: it is rebuilt when one of them changes
        mixed = [own[entry.id], *sorted((i, own[i]) for i in relations.related(entry.id))]
        fingerprint = hashlib.sha256(json.dumps(mixed).encode()).hexdigest()[:20]
        old = known.get(entry.id)
        fresh = (old is not None and old.get("fingerprint") == fingerprint
                 and (out / "jobs" / entry.id / "index.html").is_file())
        card = old["card"] if fresh else _build_job(
            entry, out, env, _related(entry, relations, by_id))
        if fresh:
            report.unchanged += 1
        else:
            report.built.append(entry.id)
        if entry.problem:
            report.problems.append(f"job {entry.id}: {entry.problem}")
        jobs[entry.id] = {"fingerprint": fingerprint, "card": card}
        cards.append(card)
        if on_job is not None:
            on_job(entry, not fresh)
    for folder in sorted((out / "jobs").iterdir()):
        if folder.is_dir() and folder.name not in jobs:
            shutil.rmtree(folder)
            report.removed.append(folder.name)

    cards.sort(key=lambda c: (c["created"], c["id"]), reverse=True)
    kinds = sorted({c["kind"] for c in cards})
    statuses = [s for s in ("succeeded", "running", "queued", "failed", "cancelled")
                if any(c["status"] == s for c in cards)]
    index = env.get_template("index.html.j2").render(root="", title=title, cards=cards,
                                                      kinds=kinds, statuses=statuses)
    _write_atomic(out / "index.html", index)
    _write_atomic(out / MANIFEST, json.dumps({"generator": "inkmotion gallery", "site": site,
                                              "jobs": jobs}, indent=1))
    report.jobs = len(cards)
    report.seconds = time.perf_counter() - started
    return report
