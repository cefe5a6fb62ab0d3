"""Jobs made from one another: the evaluation or the simulated drawing of a fit's plan.

A job that takes a plan (a ``plan`` input, as ``evaluate`` and ``simulate`` do) is linked
to the job that wrote that plan: the job whose plan.json is that very file, else one whose
plan.json has the same bytes, the first that wrote them (a submitted job works on its own
copy of its input, in its own folder).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

from inkmotion.gallery.entries import Entry


def plan_digest(path: Path) -> str | None:
    """A hash of a plan file's bytes (None when it cannot be read)."""
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


@dataclass
class Relations:
    """Who used whose plan."""

    made_from: dict[str, str] = field(default_factory=dict)  # job -> the job of its plan
    used_by: dict[str, list[str]] = field(default_factory=dict)  # job -> jobs of its plan

    def related(self, job_id: str) -> list[str]:
        """The jobs whose pages show something of ``job_id``'s page, or it of theirs."""
        source = self.made_from.get(job_id)
        return ([source] if source else []) + self.used_by.get(job_id, [])


def relate(entries: list[Entry]) -> Relations:
    """Link every plan-taking job to the job (of ``entries``) that wrote its plan."""
    by_path: dict[Path, str] = {}
    by_content: dict[str, tuple[float, str]] = {}  # plan bytes -> (created, job)
    for e in entries:
        if e.artifacts is not None and "plan.json" in e.files:
            by_path[(e.artifacts / "plan.json").resolve()] = e.id
            digest = plan_digest(e.artifacts / "plan.json")
            created = e.created.timestamp() if e.created else 0.0
            if digest is not None and (digest not in by_content
                                       or created < by_content[digest][0]):
                # the first job that wrote these bytes: a later identical run does not
                # take the links over (nor make every related page rebuild)
                by_content[digest] = (created, e.id)
    relations = Relations()
    for e in entries:
        inputs = e.spec.get("inputs") if isinstance(e.spec.get("inputs"), dict) else {}
        plan = inputs.get("plan")
        if not isinstance(plan, str):
            continue
        # the very file first (a job run on a results folder's plan), else the same bytes
        source = by_path.get(Path(plan).resolve()) or by_content.get(
            plan_digest(Path(plan)) or "", (0.0, None))[1]
        if source is not None and source != e.id:
            relations.made_from[e.id] = source
            relations.used_by.setdefault(source, []).append(e.id)
    return relations
