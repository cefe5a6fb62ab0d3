"""The job specification shared by ``inkmotion run`` and ``inkmotion submit`` (version 19).

A job is one validated spec, plain JSON (job.json), so it can travel through the broker
and reproduce a run::

    {"version": 19, "kind": "fit", "inputs": {"drawing": "tag.gml"}, "seed": 0,
     "device": "auto", "threads": 1, "record_every": 10,
     "params": {"steps": 300, ..., "initialiser": {"name": "dce", "threshold": 1.0},
                "renderer": {"name": "raster"}, "losses": [{"name": "mse"}]}}

``params`` holds the kind's own fields (declared by the job-kind plugin, see
:mod:`inkmotion.jobs.params`) with each plugin's options nested under its name. Version 1
files (flat ``input``, ``initialiser``, ``renderer``, ``losses``, ``reader`` and a flat
``params`` with ``dce_threshold`` and ``record_every``) are laid out anew on load
(:func:`upgrade_v1`, as version 2), so their job.json still reproduces their run.
Versions 2 to 19 share one layout and differ only in some defaults of the fit and of
the dce initialiser (3: the sparse, refined plan of issue 10; 4: the trace term and
rolled-back plan edits of issue 19; 5: the 'hand' sparsity of plan edits and the rapid
defaults of issue 32; 6: the trace term's worst misses, issue 32's words; 7: 400 steps
whose learning rates decay to 0.3, issue 32's speed; 8: plan edits that also target
where the motion strays from the ink; 9: plan edits kept when they bring the mean
distance within its goal, rolled back when they pin overlaps on a clamp bound; 10: a
last stage that only went on from the kept plan undone when it pins overlaps; 11: plan
edits judged with the time they add to the motion; 12: the minimum-time cost divided by
the initial plan's count of sub-movements, so edits do not make time cheaper, and the
tempo ladder; 13: 300 steps, issue 32's job time, and
the tempo ladder's mean within 0.55 px; 14: a sub-movement's arc may turn up to a half
circle, ``max_turn`` 180° where the authors clamp it at 90°; 15: the lognormals' shapes
Ac learn, ``lr_ac``, and the overlaps' floor barrier, ``w_floor``; 16: a rung of the
tempo ladder that leaves the goals backed off from, ``rapid_backs_off``, instead of
ending the fit; 17: a loop's sub-movements start at their bend, the 'dce'
initialiser's ``max_bend`` 180° and ``lr_delta`` 0.2; 18: each rung of the ladder runs its
learning rates down over its own steps, ``rapid_settle``; 19: an edit that halves a
goal's miss kept as one that meets it, ``rescue_halfway``). Those
defaults are declared once, with their history, on the parameters themselves
(``param(..., earlier={2: ...})``), so a spec keeps its version and a field it leaves
out takes that version's default when it is resolved against its kind
(:func:`inkmotion.jobs.kind.resolve`); job.json is then written as the current version
with every field spelled out. ``threads`` (any version) is the job's torch
thread count; a spec without it takes the default when the job starts
(:func:`inkmotion.devices.default_threads`), and its job.json records the count it ran with.
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from inkmotion.errors import SpecError
from inkmotion.json_files import read_json

SPEC_VERSION = 19
DEFAULT_DEVICE = "auto"
#: the largest seed a job takes (torch's generator holds 64 bits)
MAX_SEED = 2**64 - 1

_FIELDS = ("version", "kind", "inputs", "seed", "device", "threads", "record_every",
           "params")


@dataclass
class JobSpec:
    """One job: a kind, its named inputs, its parameters (raw JSON), seed and device."""

    kind: str = "fit"
    inputs: dict[str, str] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    seed: int = 0
    device: str = DEFAULT_DEVICE  # cpu, cuda, cuda:N or auto (CUDA when present)
    record_every: int = 10  # rendered images into recording.rrd every k steps (0: none)
    version: int = SPEC_VERSION
    #: torch intra-op threads on the CPU; None: decided when the job starts
    #: (:func:`inkmotion.devices.default_threads`) and written into its job.json
    threads: int | None = None

    @property
    def label(self) -> str:
        """A short description for listings: the inputs' values."""
        return ", ".join(str(v) for v in self.inputs.values())

    def named_by_file(self, message: str) -> str:
        """``message`` with each input file's full path cut to the file's name: the inputs
        of a queued or a studio job are copies under the data directory, whose path means
        nothing to the user (and shows the server's folders)."""
        for value in self.inputs.values():
            text = str(value)
            if Path(text).is_absolute() and Path(text).name:
                message = message.replace(text, Path(text).name)
        return message

    def to_dict(self) -> dict[str, Any]:
        return {"version": self.version, "kind": self.kind, "inputs": dict(self.inputs),
                "seed": self.seed, "device": self.device,
                **({"threads": self.threads} if self.threads is not None else {}),
                "record_every": self.record_every, "params": copy.deepcopy(self.params)}

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=1)

    def copy(self) -> JobSpec:
        return JobSpec.from_dict(self.to_dict())

    @classmethod
    def from_dict(cls, d: Any, source: str = "job spec") -> JobSpec:
        """A spec from its JSON form (versions 1 to 5, or a job.json wrapping it)."""
        if not isinstance(d, dict):
            raise SpecError(f"{source}: a job spec must be a JSON object.")
        d = dict(d.get("spec", d))  # a job.json wraps the spec
        if d.get("version", 1) == 1 and "inputs" not in d:
            d = upgrade_v1(d, source)
        if d.get("version") not in range(2, SPEC_VERSION + 1):
            raise SpecError(f"{source}: spec version {d.get('version')!r} is not supported; "
                            f"this inkmotion reads versions 1 to {SPEC_VERSION}.")
        unknown = sorted(set(d) - set(_FIELDS))
        if unknown:
            raise SpecError(f"{source}: unknown field(s) {', '.join(unknown)}; known fields "
                            f"are {', '.join(_FIELDS)}.")
        spec = cls(**{k: copy.deepcopy(v) for k, v in d.items()})
        _check_types(spec, source)
        return spec

    @classmethod
    def load(cls, path: str | Path) -> JobSpec:
        return cls.from_dict(read_json(path, SpecError, "job file"), str(path))


def _check_types(spec: JobSpec, source: str) -> None:
    if not isinstance(spec.kind, str) or not spec.kind:
        raise SpecError(f"{source}: kind must name a job kind, e.g. \"fit\".")
    if not isinstance(spec.inputs, dict) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in spec.inputs.items()):
        raise SpecError(f"{source}: inputs must map input names to strings, e.g. "
                        "{\"drawing\": \"tag.gml\"}.")
    if not isinstance(spec.params, dict):
        raise SpecError(f"{source}: params must be a JSON object.")
    for name in ("seed", "record_every"):
        value = getattr(spec, name)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise SpecError(f"{source}: {name}={value!r} must be a non-negative integer.")
    if spec.seed > MAX_SEED:
        raise SpecError(f"{source}: seed={spec.seed} is too large; give one below 2^64 "
                        f"(at most {MAX_SEED}).")
    threads = spec.threads
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int)
                                or threads < 1):
        raise SpecError(f"{source}: threads={threads!r} must be a positive integer (torch "
                        "threads of the job), or left out for the default.")
    if not isinstance(spec.device, str) or not spec.device:
        raise SpecError(f"{source}: device must be cpu, cuda, cuda:N or auto.")


def upgrade_v1(d: dict[str, Any], source: str = "job spec") -> dict[str, Any]:
    """A version-1 spec (the fit job's flat layout) in the version-2 layout; it then takes
    version 2's defaults where it leaves a field out, like a version-2 spec.

    v1: ``{kind, input, initialiser, renderer, losses, reader, params: {..., dce_threshold,
    record_every}, seed, device}``; the DCE threshold moves under the initialiser, the
    recording setting to the top level, the plugins into params.
    """
    known = {"kind", "input", "initialiser", "renderer", "losses", "reader", "params",
             "seed", "device", "version"}
    unknown = sorted(set(d) - known)
    if unknown:
        raise SpecError(f"{source}: unknown field(s) {', '.join(unknown)}; known fields "
                        f"are {', '.join(sorted(known))}.")
    params = dict(d.get("params") or {})
    if not isinstance(params, dict):
        raise SpecError(f"{source}: params must be a JSON object.")
    record_every = params.pop("record_every", 10)
    initialiser: dict[str, Any] = {"name": d.get("initialiser", "dce")}
    threshold = params.pop("dce_threshold", None)
    if threshold is not None and initialiser["name"] == "dce":
        initialiser["threshold"] = threshold
    params["initialiser"] = initialiser
    params["renderer"] = {"name": d.get("renderer", "raster")}
    losses = d.get("losses", ["mse"])
    params["losses"] = [{"name": n} for n in losses] if isinstance(losses, list) else losses
    if d.get("reader") is not None:
        params["reader"] = {"name": d["reader"]}
    return {"version": 2, "kind": d.get("kind", "fit"),
            "inputs": {"drawing": d.get("input", "")}, "seed": d.get("seed", 0),
            "device": d.get("device", "cpu"), "record_every": record_every, "params": params}
