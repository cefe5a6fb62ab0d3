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
                raise InputError(f"{source}: holds NaN or infinite values.")
        if not plans or not all(math.isfinite(c) and c > 0 for c in canvas):
            raise InputError(f"{source}: needs a positive canvas and at least one path.")
        return cls(canvas, plans)

    @classmethod
    def load(cls, path: str | Path) -> Drawing:
        return cls.from_dict(read_json(path, InputError, "plan file"), str(path))
