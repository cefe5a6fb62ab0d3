"""The optimiser loop: Adam on the motor plans through the differentiable renderer.

Each step evaluates the :class:`~inkmotion.fitting.objective.Objective` (ΣΛ kinematics →
Hermite Bézier segments → render → image losses + λ·L_smooth + canvas term), then takes an
Adam step with per-parameter learning rates and a cosine decay, and applies the clamps
Δt ∈ [0.1, 0.9], δ ∈ [−π/2, π/2], Ac ∈ [1e-4, 0.1] (DESIGN.md § Fitting defaults).

A 3-D plan (x, y, r: the stroke radius in px, the 2.5D extension) is optimised as two
leaves, the targets' x, y (N, 2) at ``lr_points`` and their radii r (N, 1) at
``lr_radius``, joined by ``torch.cat`` into the (N, 3) points of every step (a copy of
3N numbers), with r clamped to ``radius_range`` after each step. A 2-D plan keeps its
single points leaf: the same arithmetic, bit for bit, as before radii existed.

No host synchronisation inside a step: loss terms stay 0-d tensors on the device and go to
the observers as such (they read them when they show them); the loss is checked for NaN
only every ``check_every`` steps and at the end, with one read of an accumulated flag.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import torch

from inkmotion.errors import InkmotionError
from inkmotion.events import StepState, scalars, wants
from inkmotion.fitting.objective import Evaluation, Objective
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.params import AC_RANGE, DELTA_RANGE, DELTA_T_RANGE
from inkmotion.sigma_lognormal.plan import MotorPlan


@dataclass(frozen=True)
class OptimiserSettings:
    """Adam settings of a fit (defaults: the authors', DESIGN.md § Fitting defaults)."""

    steps: int = 300
    lr_points: float = 2.0
    lr_delta_t: float = 0.05
    lr_delta: float = 0.1
    lr_ac: float = 0.0  # 0 keeps Ac fixed
    lr_final: float = 0.1  # cosine decay to this fraction
    #: the decay's position: these steps run from step ``schedule_start`` of a schedule of
    #: ``schedule_total`` steps (None: ``steps``), so the stages of one fit share a decay
    schedule_start: int = 0
    schedule_total: int | None = None
    check_every: int = 25  # read the NaN flag from the device every k steps
    #: px per step of a 3-D plan's radius. Adam moves a parameter by about its learning
    #: rate per step, so 0.1 px crosses the whole default range (3.5 px) in ~40 steps of a
    #: 300-step fit, while one step changes a stroke's width by ≤ 0.2 px, well inside the
    #: 1-px anti-aliasing ramp whose gradient drives it (targets move 20× faster: they
    #: travel tens of px, a radius a few)
    lr_radius: float = 0.1
    #: px, the clamp of a 3-D plan's radius. Below 0.5 px (a 1-px line) the coverage
    #: clamp(r + ½ − d, 0, 1) never reaches full ink and a stroke could fade out to cheat
    #: the image loss (a pen lift the motor plan does not have); 4 px (an 8-px brush, 2.3 %
    #: of the 350-px canvas) brackets the 3-px default pen generously without letting
    #: strokes blot out the shape, and bounds the renderer's patch size
    radius_range: tuple[float, float] = (0.5, 4.0)


@dataclass
class FitResult:
    plans: list[MotorPlan]
    initial_terms: dict[str, float]
    final_terms: dict[str, float]
    initial_t_end: list[float]
    final_t_end: list[float]
    rendered: torch.Tensor  # (H, W) final
    wall_s: float
    steps: int
    #: the optimiser's parameters ``leaves`` and Adam moments ``adam`` after the last step
    #: (``optimise``'s ``resume`` continues from it, e.g. after a rolled-back plan edit)
    state: dict | None = None


def cosine(step: int, total: int, final: float) -> float:
    """Learning-rate factor: cosine decay from 1 to ``final`` over ``total`` steps."""
    return final + (1.0 - final) * 0.5 * (1.0 + math.cos(math.pi * min(step, total) / total))


class Adam:
    """Adam (β = 0.9, 0.999, ε = 1e-8) with one learning rate per parameter tensor, through
    torch's functional ``torch.optim.adam.adam``: the same arithmetic as
    ``torch.optim.Adam`` (the CPU fit reproduces bit for bit), without the import of
    ``torch._dynamo`` that the class does on first use (1.2–1.7 s per process here)."""

    def __init__(self, groups: list[tuple[torch.Tensor, float]]) -> None:
        self.params = [p for p, _ in groups]
        self.lrs = [lr for _, lr in groups]
        self.exp_avg = [torch.zeros_like(p, memory_format=torch.preserve_format)
                        for p in self.params]
        self.exp_avg_sq = [torch.zeros_like(p, memory_format=torch.preserve_format)
                           for p in self.params]
        # step counters on the CPU, as torch.optim.Adam keeps them: reading one is free
        self.steps = [torch.tensor(0.0, dtype=torch.float32) for _ in self.params]

    def zero_grad(self) -> None:
        for p in self.params:
            p.grad = None

    def state(self) -> dict[str, list[torch.Tensor]]:
        """Copies of the moments and step counters (for a checkpoint)."""
        return {"exp_avg": [t.detach().clone() for t in self.exp_avg],
                "exp_avg_sq": [t.detach().clone() for t in self.exp_avg_sq],
                "steps": [t.clone() for t in self.steps]}

    def load_state(self, state: dict[str, list[torch.Tensor]]) -> None:
        """Continue from :meth:`state`'s copies (same parameters, same order)."""
        with torch.no_grad():
            for mine, saved in ((self.exp_avg, state["exp_avg"]),
                                (self.exp_avg_sq, state["exp_avg_sq"]),
                                (self.steps, state["steps"])):
                assert len(mine) == len(saved), "a checkpoint of another optimiser"
                for t, v in zip(mine, saved, strict=True):
                    t.copy_(v.to(t.device))

    def step(self, factor: float = 1.0) -> None:
        """One update with every learning rate scaled by ``factor`` (the schedule)."""
        from torch.optim.adam import adam

        with torch.no_grad():
            for i, p in enumerate(self.params):
                if p.grad is None:
                    continue
                adam([p], [p.grad], [self.exp_avg[i]], [self.exp_avg_sq[i]], [],
                     [self.steps[i]], amsgrad=False, beta1=0.9, beta2=0.999,
                     lr=self.lrs[i] * factor, weight_decay=0.0, eps=1e-8, maximize=False)


def _terms(ev: Evaluation) -> dict[str, torch.Tensor]:
    """Every loss term and the total, detached 0-d tensors (no synchronisation)."""
    out = {k: v.detach() for k, v in ev.terms.items()}
    out["total"] = ev.total.detach()
    return out


def _not_finite() -> InkmotionError:
    return InkmotionError("The optimisation produced a non-finite loss (NaN); lower the learning "
                          "rates or check the input for extreme coordinates.")


class _StepStates:
    """Builds each step's :class:`StepState`, with heavy data only where an observer asks."""

    def __init__(self, observers: object, plans: list[MotorPlan], total: int) -> None:
        self.observers = observers
        self.total = total
        self.moves = [p.m for p in plans]  # static for the fit: no read from the device
        self.points = [m + 1 for m in self.moves]

    def __call__(self, step: int, ev: Evaluation, batch: PlanBatch) -> StepState:
        state = StepState(step, self.total, _terms(ev), ev.t_end.detach().mean())
        if wants(self.observers, "image", step):
            state.rendered = ev.rendered.detach()
        if wants(self.observers, "geometry", step):
            # samples per path n_p = k·m_p + 1, k read from the (static) shape: no sync
            k = (ev.positions.shape[0] - len(self.moves)) // max(sum(self.moves), 1)
            counts = [k * m + 1 for m in self.moves]
            state.positions = list(torch.split(ev.positions.detach(), counts))
            state.speeds = list(torch.split(ev.velocities.detach()[:, :2].norm(dim=1), counts))
            state.targets = list(torch.split(batch.points.detach(), self.points))
        return state


def optimise(
    plans: list[MotorPlan],
    objective: Objective,
    settings: OptimiserSettings,
    observers: object = None,
    *,
    resume: dict | None = None,
    checkpoint: object = None,
) -> FitResult:
    """Fit ``plans`` for ``settings.steps`` Adam steps; returns the final (detached) plans.

    ``observers`` (an object with optional ``on_step`` / ``wants_image`` /
    ``wants_geometry``, e.g. the shell's observer group) sees every step. ``checkpoint``
    (optional, with ``due(step)`` and ``save(step, state)``) is handed the optimiser's
    state — its parameters ``leaves`` and Adam moments ``adam`` — after the steps it says
    are due; ``resume``, such a state plus its ``step``, continues from that step exactly
    (the same arithmetic as an uninterrupted run).
    """
    start = time.perf_counter()
    src = PlanBatch.from_plans([p.detached() for p in plans])
    three = src.points.shape[1] == 3  # radius coordinate (2.5D): its own leaf
    leaves = {k: getattr(src, k).clone().requires_grad_(True)
              for k in ("points", "delta_t", "delta", "ac")}
    if three:
        del leaves["points"]
        leaves["xy"] = src.points[:, :2].clone().requires_grad_(True)  # (N, 2)
        leaves["r"] = src.points[:, 2:].clone().requires_grad_(True)  # (N, 1)

    def assemble() -> PlanBatch:
        """The batch of the current leaves; for 3-D plans points = [xy | r] (N, 3)."""
        points = torch.cat((leaves["xy"], leaves["r"]), 1) if three else leaves["points"]
        return PlanBatch(points, leaves["delta_t"], leaves["delta"], leaves["ac"], src.T,
                         src.moves, src.widths)

    groups = ([(leaves["xy"], settings.lr_points), (leaves["r"], settings.lr_radius)] if three
              else [(leaves["points"], settings.lr_points)])
    groups += [(leaves["delta_t"], settings.lr_delta_t), (leaves["delta"], settings.lr_delta)]
    if settings.lr_ac > 0:
        groups.append((leaves["ac"], settings.lr_ac))
    optimiser = Adam(groups)
    first_step = 1
    if resume is not None:
        with torch.no_grad():
            for name, value in resume["leaves"].items():
                leaves[name].copy_(value.to(leaves[name].device))
        optimiser.load_state(resume["adam"])
        first_step = int(resume["step"]) + 1
    batch = assemble()
    on_step = getattr(observers, "on_step", None)
    states = _StepStates(observers, plans, settings.steps)

    with torch.no_grad():
        first = objective(batch)
    initial_terms = scalars(_terms(first))
    if not math.isfinite(initial_terms["total"]):
        raise _not_finite()
    initial_t_end = first.t_end.tolist()
    if resume is not None and "initial_terms" in resume:  # the terms before step 1
        initial_terms, initial_t_end = resume["initial_terms"], resume["initial_t_end"]
    if resume is not None and resume.get("objective"):
        objective.load_state(resume["objective"])
    finite = torch.ones((), dtype=torch.bool, device=src.points.device)  # all steps so far
    for step in range(first_step, settings.steps + 1):
        optimiser.zero_grad()
        if three:
            batch = assemble()  # a new graph from the updated leaves
        ev = objective(batch, step)
        ev.total.backward()
        optimiser.step(cosine(settings.schedule_start + step - 1,
                              settings.schedule_total or settings.steps, settings.lr_final))
        with torch.no_grad():
            leaves["delta_t"].clamp_(*DELTA_T_RANGE)
            leaves["delta"].clamp_(*DELTA_RANGE)
            leaves["ac"].clamp_(*AC_RANGE)
            if three:
                leaves["r"].clamp_(*settings.radius_range)
            finite = finite & torch.isfinite(ev.total.detach())
        if step % settings.check_every == 0 and not bool(finite):
            raise _not_finite()
        if on_step is not None:
            on_step(states(step, ev, batch))
        if checkpoint is not None and checkpoint.due(step):  # type: ignore[attr-defined]
            checkpoint.save(step, {  # type: ignore[attr-defined]
                "leaves": {k: v.detach().clone() for k, v in leaves.items()},
                "adam": optimiser.state(), "initial_terms": initial_terms,
                "initial_t_end": initial_t_end, "objective": objective.state()})

    with torch.no_grad():
        batch = assemble()
        last = objective(batch)
    final_terms = scalars(_terms(last))
    if not bool(finite) or not math.isfinite(final_terms["total"]):
        raise _not_finite()
    result_plans = PlanBatch(*(t.detach().clone() for t in (
        batch.points, batch.delta_t, batch.delta, batch.ac, batch.T)), src.moves,
        src.widths).to_plans()
    return FitResult(
        plans=result_plans,
        initial_terms=initial_terms,
        final_terms=final_terms,
        initial_t_end=initial_t_end,
        final_t_end=last.t_end.tolist(),
        rendered=last.rendered.detach(),
        wall_s=time.perf_counter() - start,
        steps=settings.steps,
        state={"leaves": {k: v.detach().clone() for k, v in leaves.items()},
               "adam": optimiser.state()},
    )
