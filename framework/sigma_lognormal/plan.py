"""The motor plan of one trajectory and the plan.json file format.

A :class:`MotorPlan` is one pen-down stroke sequence: an initial position p0 followed
by virtual targets p1..pm (2-D, or 3-D where the third coordinate is the stroke radius
in px: the 2.5D extension), and per sub-movement i = 1..m the overlap Δt_i, the turning
angle δ_i of the circular arc, the shape Ac_i and the ±3σ duration T_i.

A :class:`Drawing` is a canvas and several motor plans, one per trajectory (pen lift
between them); it is what plan.json holds.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import torch

from inkmotion.errors import InputError
from inkmotion.json_files import read_json

PLAN_FORMAT_VERSION = 1
DEFAULT_T = 0.8
DEFAULT_AC = 0.01
DEFAULT_WIDTH = 3.0


@dataclass
class MotorPlan:
    """Motor plan of one trajectory (tensors; any may require grad)."""

    points: torch.Tensor  # (m+1, D), D in {2, 3}
    delta_t: torch.Tensor  # (m,)
    delta: torch.Tensor  # (m,)
    ac: torch.Tensor  # (m,)
    T: torch.Tensor  # (m,)
    width: float = DEFAULT_WIDTH

    def __post_init__(self) -> None:
        m = self.points.shape[0] - 1
        assert m >= 1 and self.points.shape[1] in (2, 3), self.points.shape
        for name in ("delta_t", "delta", "ac", "T"):
            assert getattr(self, name).shape == (m,), (name, getattr(self, name).shape, m)

    @classmethod
    def from_points(
        cls,
        points: torch.Tensor | list,
        *,
        delta_t: float = 1.0,
        delta: float = 0.0,
        ac: float = DEFAULT_AC,
        T: float = DEFAULT_T,
        width: float = DEFAULT_WIDTH,
        dtype: torch.dtype = torch.float32,
        device: torch.device | str | None = None,
    ) -> MotorPlan:
        """A plan through ``points`` with the initialisation defaults (Δt = 1, δ = 0)."""
        p = torch.as_tensor(points, dtype=dtype, device=device)
        m = p.shape[0] - 1
        full = lambda v: torch.full((m,), float(v), dtype=dtype, device=p.device)  # noqa: E731
        return cls(p, full(delta_t), full(delta), full(ac), full(T), float(width))

    @property
    def m(self) -> int:
        """Number of sub-movements."""
        return self.points.shape[0] - 1

    @property
    def dim(self) -> int:
        return self.points.shape[1]

    @property
    def end_time(self) -> torch.Tensor:
        """T_end = t0_m + e^{μ_m + 3σ_m} (scalar tensor, differentiable)."""
        from inkmotion.sigma_lognormal.batch import PlanBatch

        return PlanBatch.from_plans([self]).end_times()[0]

    def with_radius(self, radius: float) -> MotorPlan:
        """This plan lifted to 3-D (2.5D): points (m+1, 2) → (m+1, 3) with the constant
        stroke radius ``radius`` px as third coordinate, which then moves like a 1-D
        lognormal sub-movement (the ΣΛ model). The other tensors are shared,
        not copied; a 3-D plan is returned unchanged. ``width`` is kept (a renderer ignores
        it for 3-D segments)."""
        if self.dim == 3:
            return self
        if not (math.isfinite(radius) and radius >= 0):
            raise InputError(f"A stroke radius must be a non-negative number of px, got "
                             f"{radius!r}; pass a width ≥ 0.")
        r = torch.full((self.m + 1, 1), float(radius), dtype=self.points.dtype,
                       device=self.points.device)  # (m+1, 1)
        return MotorPlan(torch.cat((self.points, r), 1), self.delta_t, self.delta, self.ac,
                         self.T, self.width)

    def detached(self) -> MotorPlan:
        return MotorPlan(*(getattr(self, k).detach().clone() for k in _TENSORS), self.width)

    def to(self, device: torch.device | str | None = None,
           dtype: torch.dtype | None = None) -> MotorPlan:
        return MotorPlan(*(getattr(self, k).to(device=device, dtype=dtype) for k in _TENSORS),
                         self.width)

    def to_dict(self) -> dict:
        """The plan.json entry of this path."""
        return {
            "points": self.points.detach().cpu().double().tolist(),
            "delta_t": self.delta_t.detach().cpu().double().tolist(),
            "delta": self.delta.detach().cpu().double().tolist(),
            "ac": self.ac.detach().cpu().double().tolist(),
            "T": self.T.detach().cpu().double().tolist(),
            "width": self.width,
        }

    @classmethod
    def from_dict(cls, d: dict, dtype: torch.dtype = torch.float32) -> MotorPlan:
        t = lambda k: torch.tensor(d[k], dtype=dtype)  # noqa: E731
        return cls(t("points"), t("delta_t"), t("delta"), t("ac"), t("T"),
                   float(d.get("width", DEFAULT_WIDTH)))

    def save(self, path: str | Path, canvas: tuple[float, float] = (350.0, 350.0)) -> None:
        """Write a one-path plan.json."""
        Drawing(canvas, [self]).save(path)

    @classmethod
    def load(cls, path: str | Path, index: int = 0) -> MotorPlan:
        """Read path number ``index`` of a plan.json (see :meth:`Drawing.load` for all)."""
        drawing = Drawing.load(path)
        if not 0 <= index < len(drawing.plans):
            raise InputError(
                f"{path}: has {len(drawing.plans)} paths, so there is no path {index}."
            )
        return drawing.plans[index]


_TENSORS = ("points", "delta_t", "delta", "ac", "T")

#: the other JSON files a job writes, told by keys only they have, so that one given for a
#: plan.json is named: (what it is, its keys)
OTHER_FILES = (("a job.json", {"spec", "versions"}), ("a report.json", {"wall_s", "kind"}),
               ("an input.json", {"traces"}), ("a benchmark's summary", {"items", "columns"}))

#: what each value of a sub-movement must be for the model to mean a movement: (field,
#: test, what it is); the onsets advance by Δt·T (Δt ≥ 0), σ = √(−ln(1 − Ac)) needs
#: 0 < Ac < 1, and an arc turns at most a full turn
RANGES: tuple[tuple[str, Callable[[torch.Tensor], torch.Tensor], str], ...] = (
    ("T", lambda v: v > 0, "a duration, positive"),
    ("ac", lambda v: (v > 0) & (v < 1), "the lognormal's shape Ac, between 0 and 1"),
    ("delta_t", lambda v: v >= 0, "an overlap Δt, 0 or more (onsets never go back)"),
    ("delta", lambda v: v.abs() < 2 * math.pi,  # 2π: h = 1/sinc(1), an endless radius
     "an arc's turn δ, less than 2π either way"),
)


def _check_counts(path: object, where: str) -> None:
    """Refuse, in one sentence, a path of plan.json with fewer than two points or with
    per-sub-movement values not one for each of its sub-movements."""
    if not isinstance(path, dict) or not isinstance(path.get("points"), list):
        return  # the parse names what is missing
    m = len(path["points"]) - 1
    if m < 1:
        raise InputError(f"{where} has {m + 1} point; a path needs its start and at least "
                         "one target; refit the plan or restore its values.")
    for name in ("delta_t", "delta", "ac", "T"):
        values = path.get(name)
        if isinstance(values, list) and len(values) != m:
            raise InputError(f"{where}.{name} has {len(values)} values for its {m} "
                             "sub-movements (one each); refit the plan or restore its "
                             "values.")


#: the largest side of a plan's canvas, px: far beyond any drawing's (a larger one is a
#: damaged file, and its scale overflows the timings made from it)
MAX_CANVAS_SIDE = 100_000
#: how far from the origin a plan's targets may lie, in sides of its canvas (a fit keeps
#: them on it; a plan edited by hand may overshoot, not by a hundred canvases)
FAR_OFF_CANVASES = 100


def _check_ranges(plan: MotorPlan, where: str) -> None:
    """Refuse, in one sentence naming the path and the value, a plan whose values are not
    a movement's (:data:`RANGES`), a width below 0 or a negative radius."""
    for name, test, meaning in RANGES:
        values = getattr(plan, name)
        bad = ~test(values)
        if bool(bad.any()):
            k = int(bad.nonzero()[0, 0])
            raise InputError(f"{where}.{name}[{k}] is {float(values[k]):g}, but it is "
                             f"{meaning}; refit the plan or restore its values.")
    if not plan.width >= 0:
        raise InputError(f"{where}.width is {plan.width:g}, but a pen's width is 0 or more; "
                         "refit the plan or restore its values.")
    if plan.points.shape[1] == 3 and bool((plan.points[:, 2] < 0).any()):
        raise InputError(f"{where}.points hold a negative radius (their third value); "
                         "refit the plan or restore its values.")


@dataclass
class Drawing:
    """A canvas (width, height) in px and one motor plan per trajectory: plan.json."""

    canvas: tuple[float, float]
    plans: list[MotorPlan] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "version": PLAN_FORMAT_VERSION,
            "canvas": {"width": self.canvas[0], "height": self.canvas[1]},
            "paths": [p.to_dict() for p in self.plans],
        }

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=1))

    @classmethod
    def from_dict(cls, d: dict, source: str = "plan.json") -> Drawing:
        if not isinstance(d, dict):
            raise InputError(f"{source}: not a plan.json (its top level is a "
                             f"{type(d).__name__}, not an object); give a fit's plan.json.")
        other = next((name for name, keys in OTHER_FILES if keys <= d.keys()), None)
        if other is not None and not isinstance(d.get("paths"), list):
            raise InputError(f"{source}: is {other}, not a plan.json; give the plan.json "
                             "beside it.")
        if "paths" not in d and "version" not in d:  # a drawing (a GML tag's JSON), say
            raise InputError(f"{source}: is not a plan.json (no paths of sub-movements: a "
                             "drawing?); fit it first (inkmotion run fit FILE --out DIR) and "
                             "give DIR/plan.json.")
        for i, path in enumerate(d.get("paths") or []):
            _check_counts(path, f"{source}: paths[{i}]")
        try:
            if d.get("version") != PLAN_FORMAT_VERSION:
                raise InputError(
                    f"{source}: plan format version {d.get('version')!r} is not supported "
                    f"(expected {PLAN_FORMAT_VERSION})."
                )
            canvas = (float(d["canvas"]["width"]), float(d["canvas"]["height"]))
            plans = [MotorPlan.from_dict(p) for p in d["paths"]]
        except InputError:
            raise
        except (KeyError, TypeError, ValueError, AssertionError, IndexError) as exc:
            raise InputError(
                f"{source}: not a valid plan.json ({type(exc).__name__}: {exc}); "
                "write it with inkmotion or follow the plan.json format in the README."
            ) from exc
        for p in plans:
            if not all(torch.isfinite(getattr(p, k)).all() for k in _TENSORS):
                raise InputError(f"{source}: holds NaN or infinite values (or numbers beyond "
                                 "a 32-bit float's 3.4e38); refit the plan or restore them.")
        if not plans or not all(math.isfinite(c) and c > 0 for c in canvas):
            raise InputError(f"{source}: needs a positive canvas and at least one path.")
        if max(canvas) > MAX_CANVAS_SIDE:
            raise InputError(f"{source}: its canvas is {canvas[0]:g} × {canvas[1]:g} px, over "
                             f"the {MAX_CANVAS_SIDE:g} px a plan's may be; refit the plan or "
                             "restore its canvas.")
        reach = FAR_OFF_CANVASES * max(canvas)
        for i, p in enumerate(plans):
            far = float(p.points[:, :2].abs().max())
            if far > reach:
                raise InputError(f"{source}: paths[{i}] has a target {far:g} px from the "
                                 f"origin, over {FAR_OFF_CANVASES} times its "
                                 f"{canvas[0]:g} × {canvas[1]:g}-px canvas; refit the plan or "
                                 "restore its values.")
        for i, p in enumerate(plans):
            _check_ranges(p, f"{source}: paths[{i}]")
        return cls(canvas, plans)

    @classmethod
    def load(cls, path: str | Path) -> Drawing:
        try:
            with open(path, "rb") as f:
                head = f.read(256).lstrip()
        except OSError:
            head = b""  # read_json says why
        if head.startswith(b"<"):  # XML: a GML tag or an SVG
            raise InputError(f"{path}: is a drawing (XML), not a plan.json; fit it first "
                             f"(inkmotion run fit {path} --out DIR) and give DIR/plan.json.")
        return cls.from_dict(read_json(path, InputError, "plan file"), str(path))
