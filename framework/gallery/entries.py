"""What the gallery shows of one job: :class:`Entry`, read from the job store or a folder.

Two sources, one shape:

- a job-store row (:func:`from_record`): its status, progress, timings and metrics, and —
  once it has succeeded — the artifact folder in the data directory;
- a results folder written by ``inkmotion run … --out DIR`` (:func:`from_folder`): the
  folder exists only once complete (it is committed atomically), so it has succeeded.

Everything a page needs is read here, never in the templates, and nothing here raises on
a damaged job: an unreadable report.json or a missing artifact folder becomes a
``problem`` shown on the card (the build goes on and prints it).
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from inkmotion.errors import InputError, ServiceError, SpecError
from inkmotion.json_files import read_json

#: images a job may write, in the order a detail page shows them, with their captions; the
#: first present is the card's thumbnail. Other PNGs (a plugin's own) follow, by name.
FIGURES: tuple[tuple[str, str], ...] = (
    ("sim_drawing.png", "Drawn by the simulated Franka Panda (MuJoCo)"),
    ("overlay.png", "The fitted motion over its target"),
    ("drawing.png", "The drawing"),
    ("plan_drawing.png", "The motor plan, drawn"),
    ("spray.png", "Spray-paint preview"),
    ("side_by_side.png", "Plan and simulated drawing side by side"),
    ("speed.png", "Pen speed and its sub-movements"),
    ("minima.png", "Speed minima along the path"),
    ("speeds.png", "Speed profiles: ΣΛ, minimum jerk and time-optimal"),
    ("human_speeds.png", "Fitted speed against the recorded human speed"),
    ("init.png", "The initial motor plan"),
    ("saliency.png", "Saliency"),
    ("photo.png", "The input photo"),
    ("plot_preview.png", "The plot on its paper: pen-down strokes and pen-up travel"),
    ("feed.png", "The plotter's feed along the strokes, beside the ΣΛ speed"),
)
#: files a reader downloads first, in this order; every other artifact follows by name
DOWNLOADS = ("drawing.svg", "plan.json", "trajectory.csv", "recording.rrd", "job.json",
             "report.json")
#: the figures a card shows, per kind, when the job reports them (another kind: its own
#: first three); the job's page shows them all
CARD_METRICS: dict[str, tuple[str, ...]] = {
    "fit": ("t_end_ratio", "moves", "chamfer_mean_px", "chamfer_max_px"),
    "tag": ("t_end_ratio", "moves", "clip_similarity"),
    "abstract": ("t_end_ratio", "moves", "clip_similarity"),
    "simulate": ("duration_s", "tracking_down_plane_rms_mm", "contact_coverage"),
    "draw": ("duration_s", "tracking_down_plane_rms_mm", "flange_max_mm"),
    "plot": ("estimated_s", "peak_feed", "travel_mm"),
    "evaluate": ("minimum-jerk_msj_ratio", "minimum-jerk_ldj_ratio",
                 "time-optimal_duration_ratio"),
}


@dataclass
class Entry:
    """One job as the gallery shows it (plain data: the templates only format it)."""

    id: str  # the job id, or ``run-<folder>-<hash>`` for a results folder
    source: str  # "store" or "folder"
    kind: str
    status: str
    label: str  # the input(s)
    created: datetime | None
    duration_s: float | None
    t_end_ratio: float | None
    metrics: dict[str, Any]
    spec: dict[str, Any]  # the whole spec (job.json's, or the store's for a job not run yet)
    artifacts: Path | None  # the artifact folder when it exists
    files: list[str] = field(default_factory=list)  # its regular files, sorted
    progress: tuple[int, int] | None = None  # (step, total) while queued or running
    error: str | None = None  # a failed job's error
    problem: str | None = None  # what is wrong with its files, for the card and the log
    report: dict[str, Any] = field(default_factory=dict)
    job_json: Path | None = None  # the job.json that reproduces it

    @property
    def params(self) -> dict[str, Any]:
        """The spec's parameters as JSON."""
        params = self.spec.get("params")
        return params if isinstance(params, dict) else {}

    @property
    def writes_spec(self) -> bool:
        """A store job with no job.json yet (queued, running, failed): its page holds the
        store's spec as files/spec.json, to run it again from."""
        return self.job_json is None and self.source == "store"

    @property
    def thumbnail(self) -> str | None:
        """The artifact the card shows (the first of :data:`FIGURES` present)."""
        return next((name for name, _ in FIGURES if name in self.files), None)

    def fingerprint(self) -> str:
        """A hash of everything the job's page shows: its figures and its files' names,
        sizes and modification times; the page is rebuilt when it changes."""
        state: list[Any] = [self.id, self.kind, self.status, self.label, self.duration_s,
                            self.t_end_ratio, self.metrics, self.spec, self.progress,
                            self.error, self.problem, str(self.artifacts),
                            str(self.job_json)]
        if self.artifacts is not None:
            for name in self.files:
                st = (self.artifacts / name).stat()
                state.append((name, st.st_size, st.st_mtime_ns))
        blob = json.dumps(state, sort_keys=True, default=str).encode()
        return hashlib.sha256(blob).hexdigest()[:20]


def _files(folder: Path | None) -> list[str]:
    if folder is None or not folder.is_dir():
        return []
    return sorted(p.name for p in folder.iterdir() if p.is_file() and not p.name.startswith("."))


def _read_json(path: Path) -> tuple[dict[str, Any], str | None]:
    """The JSON object in ``path`` and None, or ``{}`` and what is wrong with it."""
    if not path.is_file():
        return {}, None
    try:
        value = read_json(path, InputError, "JSON file")
    except (InputError, OSError) as exc:
        return {}, f"{path.name} is unreadable: {exc}"
    if not isinstance(value, dict):
        return {}, f"{path} does not hold a JSON object"
    return value, None


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) \
        else None


def from_record(record: Any) -> Entry:
    """The entry of a job-store row (:class:`inkmotion.store.JobRecord`)."""
    artifacts = Path(record.artifact_dir) if record.artifact_dir else None
    problem = None
    if record.status == "succeeded" and (artifacts is None or not artifacts.is_dir()):
        problem = (f"its artifact folder {artifacts} is missing (moved or deleted); "
                   "its figures come from the job store only")
        artifacts = None
    report, bad = _read_json(artifacts / "report.json") if artifacts else ({}, None)
    duration = None
    if record.started_at is not None and record.finished_at is not None:
        duration = (record.finished_at - record.started_at).total_seconds()
    metrics = dict(record.metrics or report.get("metrics") or {})
    t_end = _number(metrics.get("t_end_ratio"))
    progress = None
    if record.status in ("queued", "running"):
        progress = (int(record.step), int(record.total))
    spec = record.spec if isinstance(record.spec, dict) else {}
    job_json = artifacts / "job.json" if artifacts and (artifacts / "job.json").is_file() \
        else None
    if job_json is not None:  # the resolved spec (every default filled in) of the run
        job, _ = _read_json(job_json)
        spec = job["spec"] if isinstance(job.get("spec"), dict) else spec
    return Entry(id=record.id, source="store", kind=record.kind, status=record.status,
                 label=record.label or ", ".join(map(str, (spec.get("inputs") or {}).values())),
                 created=record.created_at, duration_s=duration, t_end_ratio=t_end,
                 metrics=metrics, spec=spec,
                 artifacts=artifacts, files=_files(artifacts), progress=progress,
                 error=record.error, problem=problem or bad, report=report,
                 job_json=job_json)


def folder_id(folder: Path) -> str:
    """A stable id for a results folder: its name (made URL-safe) and a hash of its path."""
    slug = re.sub(r"[^A-Za-z0-9_-]+", "-", folder.name).strip("-")[:40] or "run"
    digest = hashlib.sha1(str(folder.resolve()).encode()).hexdigest()[:8]
    return f"run-{slug}-{digest}"


def from_folder(folder: Path) -> Entry:
    """The entry of a results folder (one holding job.json, as ``inkmotion run`` writes)."""
    folder = folder.resolve()
    job, bad_job = _read_json(folder / "job.json")
    report, bad_report = _read_json(folder / "report.json")
    spec = job.get("spec") if isinstance(job.get("spec"), dict) else {}
    inputs = spec.get("inputs") if isinstance(spec.get("inputs"), dict) else {}
    metrics = dict(report.get("metrics") or {})
    created = datetime.fromtimestamp((folder / "job.json").stat().st_mtime, timezone.utc)
    return Entry(id=folder_id(folder), source="folder",
                 kind=str(spec.get("kind") or report.get("kind") or "?"), status="succeeded",
                 label=", ".join(map(str, inputs.values())) or folder.name, created=created,
                 duration_s=_number(report.get("wall_s")),
                 t_end_ratio=_number(metrics.get("t_end_ratio")), metrics=metrics,
                 spec=spec, artifacts=folder,
                 files=_files(folder), problem=bad_job or bad_report, report=report,
                 job_json=folder / "job.json")


def find_result_folders(root: Path, depth: int = 3) -> list[Path]:
    """Results folders (holding job.json) at or under ``root``, at most ``depth`` levels
    down; a job's staging (``*.partial-*``) or replaced (``*.old-*``) folder is skipped."""
    found: list[Path] = []

    def walk(folder: Path, level: int) -> None:
        if ".partial-" in folder.name or ".old-" in folder.name:
            return
        if (folder / "job.json").is_file():
            found.append(folder)
            return
        if level < depth:
            for child in sorted(p for p in folder.iterdir() if p.is_dir()):
                walk(child, level + 1)

    walk(root, 0)
    return found


def collect(*, store: bool = True, folders: Iterable[str | Path] = (),
            db_url: str | None = None) -> list[Entry]:
    """Every job of the job store (``store``) and every results folder under ``folders``.

    Raises :class:`ServiceError` when the store cannot be read and :class:`SpecError` for
    a folder that does not exist or holds no results, each naming it and what to do."""
    entries: list[Entry] = []
    if store:
        entries += [from_record(r) for r in _store_records(db_url)]
    for root in folders:
        root = Path(root)
        if not root.is_dir():
            what = "is a file, not a folder" if root.is_file() else "no such folder"
            raise SpecError(f"--from {root}: {what}; give a folder of results written by "
                            "`inkmotion run ... --out DIR`.")
        found = find_result_folders(root)
        if not found:
            raise SpecError(f"--from {root}: no results in it (no job.json at most 3 levels "
                            "down); give a folder written by `inkmotion run ... --out DIR`.")
        entries += [from_folder(f) for f in found]
    return entries


def _store_records(db_url: str | None) -> list[Any]:
    import sqlalchemy.exc

    from inkmotion.settings import load_settings
    from inkmotion.store import list_jobs

    url = db_url or load_settings().db_url
    try:
        return list_jobs(limit=None, db_url=url)
    except sqlalchemy.exc.SQLAlchemyError as exc:
        reason = str(exc.orig if getattr(exc, "orig", None) else exc).strip().splitlines()[0]
        raise ServiceError(f"The job store {_shown_url(url)} cannot be read ({reason}); start "
                           "it, or build from results folders only with --no-store --from "
                           "DIR.") from None


def _shown_url(url: str) -> str:
    """The URL without its password."""
    return re.sub(r"://([^:/@]+):[^@]*@", r"://\1:***@", url)
