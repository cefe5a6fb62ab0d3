"""The job specification shared by ``inkmotion run`` and ``inkmotion submit``.

A job is one validated spec: a kind, an input, plugin names, parameters and a seed. It is
plain JSON (job.json), so it can travel through the broker and reproduce a run.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from inkmotion.errors import SpecError
from inkmotion.json_files import read_json

KINDS = ("fit",)
SPEC_VERSION = 1


@dataclass
class FitParams:
    """Optimiser settings; defaults are the authors' (DESIGN.md § Fitting defaults)."""

    steps: int = 300
    size: int = 350  # canvas longer side, px
    width: float = 3.0  # stroke width, px
    # λ on mean over paths of T_end/m + w_σ·Var Δt. The authors' demo uses 70 against
    # 200·MSE; with our renderer and MSE scale 70 pins every Δt at its 0.1 floor and cuts
    # corners (49867.json: max Chamfer 6.0 px), while 20 reaches the same T_end (0.14×)
    # with a max of 0.9 px, so 20 is the default.
    lambda_smooth: float = 20.0
    w_image: float = 200.0  # w_I on the image loss
    w_sigma: float = 50.0
    w_canvas: float = 1.0  # keeps virtual targets inside the canvas
    lr_points: float = 2.0
    lr_delta_t: float = 0.05
    lr_delta: float = 0.1
    lr_ac: float = 0.0  # 0 keeps Ac fixed
    lr_final: float = 0.1  # cosine decay to this fraction
    dce_threshold: float = 1.0  # DCE relevance threshold, px
    samples_per_move: int = 5
    record_every: int = 10  # rendered images into the recording every k steps (0: none)

    def validate(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise SpecError(f"Parameter {f.name}={v!r} must be a finite number.")
            if v < 0:
                raise SpecError(f"Parameter {f.name}={v!r} must not be negative.")
        if not 1 <= self.steps <= 100_000:
            raise SpecError(f"Parameter steps={self.steps} must be between 1 and 100000.")
        if not 32 <= self.size <= 4096:
            raise SpecError(f"Parameter size={self.size} must be between 32 and 4096 px.")
        if self.width <= 0:
            raise SpecError(f"Parameter width={self.width} must be positive.")
        if self.samples_per_move < 1:
            raise SpecError("Parameter samples_per_move must be at least 1.")


@dataclass
class JobSpec:
    """One job. ``input`` is a file path or ``text:WORD``; plugins are named, not imported."""

    kind: str = "fit"
    input: str = ""
    initialiser: str = "dce"
    renderer: str = "raster"
    losses: list[str] = field(default_factory=lambda: ["mse"])
    reader: str | None = None  # None: the first reader that can read the input
    params: FitParams = field(default_factory=FitParams)
    seed: int = 0
    device: str = "cpu"
    version: int = SPEC_VERSION

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=1)

    @classmethod
    def from_dict(cls, d: dict[str, Any], source: str = "job spec") -> JobSpec:
        if not isinstance(d, dict):
            raise SpecError(f"{source}: a job spec must be a JSON object.")
        d = dict(d.get("spec", d))  # accept a job.json that wraps the spec
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise SpecError(f"{source}: unknown field(s) {', '.join(unknown)}; "
                            f"known fields are {', '.join(sorted(known))}.")
        params = d.pop("params", {}) or {}
        pknown = {f.name for f in fields(FitParams)}
        punknown = sorted(set(params) - pknown)
        if punknown:
            raise SpecError(f"{source}: unknown parameter(s) {', '.join(punknown)}; "
                            f"known parameters are {', '.join(sorted(pknown))}.")
        try:
            spec = cls(**d, params=FitParams(**params))
        except TypeError as exc:
            raise SpecError(f"{source}: {exc}.") from exc
        return spec

    @classmethod
    def load(cls, path: str | Path) -> JobSpec:
        return cls.from_dict(read_json(path, SpecError, "job file"), str(path))

    def validate(self, check_plugins: bool = True, check_input: bool = True) -> JobSpec:
        """Refuse a bad spec with one sentence; returns self for chaining."""
        if self.kind not in KINDS:
            raise SpecError(f"Unknown job kind {self.kind!r}; kinds are: {', '.join(KINDS)}.")
        if not isinstance(self.input, str) or not self.input:
            raise SpecError("The job has no input; give a file path or text:WORD.")
        if not isinstance(self.seed, int):
            raise SpecError(f"seed={self.seed!r} must be an integer.")
        if not isinstance(self.losses, list) or not self.losses:
            raise SpecError("The job needs at least one image loss (e.g. mse).")
        self.params.validate()
        if check_input and not self.input.startswith("text:") and not Path(self.input).is_file():
            raise SpecError(f"{self.input}: no such input file; check the path.")
        if check_plugins:
            from inkmotion.plugin_host import host

            h = host()
            h.get("initialiser", self.initialiser)
            h.get("renderer", self.renderer)
            for name in self.losses:
                h.get("image-loss", name)
            if self.reader is not None:
                h.get("reader", self.reader)
        return self
