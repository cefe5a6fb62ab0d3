"""The optimiser loop: Adam on the motor plans through the differentiable renderer.

Each step evaluates the :class:`~inkmotion.fitting.objective.Objective` (ΣΛ kinematics →
Hermite Bézier segments → render → image losses + λ·L_smooth + canvas term), then takes an
Adam step with per-parameter learning rates and a cosine decay, and applies the clamps
Δt ∈ [0.1, 0.9], δ ∈ [−``delta_limit``, ``delta_limit``], Ac ∈ [1e-4, 0.1] (the authors'
defaults, with their δ limit π/2; a fit's ``--max-turn`` sets its own).

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
from typing import Any

import torch

from inkmotion.errors import InkmotionError
from inkmotion.events import StepState, scalars, wants
from inkmotion.fitting.objective import Evaluation, Objective
from inkmotion.rng import restore_rng
from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.params import (
    AC_RANGE,
    DELTA_RANGE,
    DELTA_T_RANGE,
    delta_range,
)
from inkmotion.sigma_lognormal.plan import MotorPlan


@dataclass(frozen=True)
class OptimiserSettings:
    """Adam settings of a fit. The tunables have no defaults here: a job kind's parameters
    hold them (:class:`inkmotion.kinds.optimisation.OptimisationParams`)."""

    steps: int
    lr_points: float  # px per step of the virtual targets
    lr_delta_t: float
    lr_delta: float
    lr_ac: float  # 0 keeps Ac fixed
    lr_final: float  # cosine decay to this fraction
    #: the decay's position: these steps run from step ``schedule_start`` of a schedule of
    #: ``schedule_total`` steps (None: ``steps``), so the stages of one fit share a decay
    schedule_start: int = 0
    schedule_total: int | None = None
    check_every: int = 25  # read the NaN flag from the device every k steps
    #: px per step of a 3-D plan's radius, and its clamp (lo, hi) px; a 3-D plan needs
    #: both (the generation kinds' --lr-radius, --radius-min, --radius-max say why theirs)
    lr_radius: float = 0.0
    radius_range: tuple[float, float] | None = None
    #: the most |δ| (radians) one sub-movement's arc may turn: the clamp of the turning
    #: angles (the fitting kinds pass their ``max_turn``; here the authors' quarter circle)
    delta_limit: float = DELTA_RANGE[1]


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

    def to_data(self) -> dict[str, Any]:
        """This result as plain data — tensors, numbers, strings, lists and dicts — for a
        checkpoint, which loads with ``torch.load(weights_only=True)`` (the job's
        checkpoints are data, never code); :meth:`from_data` makes it again, bit for bit."""
        plans = [{"tensors": [p.points, p.delta_t, p.delta, p.ac, p.T], "width": p.width}
                 for p in self.plans]
        return {"plans": plans, "initial_terms": self.initial_terms,
                "final_terms": self.final_terms, "initial_t_end": self.initial_t_end,
                "final_t_end": self.final_t_end, "rendered": self.rendered,
                "wall_s": self.wall_s, "steps": self.steps, "state": self.state}

    @classmethod
    def from_data(cls, data: dict[str, Any]) -> FitResult:
        """The result :meth:`to_data` wrote."""
        plans = [MotorPlan(*p["tensors"], p["width"]) for p in data["plans"]]
        return cls(plans, data["initial_terms"], data["final_terms"], data["initial_t_end"],
                   data["final_t_end"], data["rendered"], data["wall_s"], data["steps"],
                   data["state"])


def cosine(step: int, total: int, final: float) -> float:
    """Learning-rate factor: cosine decay from 1 to ``final`` over ``total`` steps."""
    return final + (1.0 - final) * 0.5 * (1.0 + math.cos(math.pi * min(step, total) / total))


BETA1, BETA2, EPS = 0.9, 0.999, 1e-8  # torch.optim.Adam's defaults


def adam_update(params: list[torch.Tensor], grads: list[torch.Tensor],
                exp_avg: list[torch.Tensor], exp_avg_sq: list[torch.Tensor],
                steps: list[torch.Tensor], lrs: list[float], one: torch.Tensor) -> None:
    """One Adam update of ``params`` in place, parameter i at learning rate ``lrs[i]``
    (the schedule's factor applied): the moments and step counters advance, then

        m ← m + (1 − β1)·(g − m),   v ← β2·v + (1 − β2)·g²,
        p ← p − (lr / (1 − β1ⁿ))·m / (√v / √(1 − β2ⁿ) + ε)

    as ``torch.optim.Adam`` computes them, each product and sum a multi-tensor op of its
    own, rounded on its own. torch's fused forms (``lerp``, ``addcmul``, ``addcdiv``)
    round a product and a sum once (a fused multiply-add) in their vector kernels and
    twice in their scalar ones, so their bits depended on the CPU; these round alike on
    every CPU (:mod:`inkmotion.portable_math`). No device read: the step counters live on
    the CPU.
    """
    with torch.no_grad():
        torch._foreach_add_(steps, one, alpha=1.0)  # as torch does: 1 wrapped once
        change = torch._foreach_sub(grads, exp_avg)
        torch._foreach_mul_(change, 1 - BETA1)
        torch._foreach_add_(exp_avg, change)
        torch._foreach_mul_(exp_avg_sq, BETA2)
        squares = torch._foreach_mul(grads, grads)
        torch._foreach_mul_(squares, 1 - BETA2)
        torch._foreach_add_(exp_avg_sq, squares)
        counts = [float(t) for t in steps]  # CPU counters: no device read
        step_size = [(lr / (1 - BETA1 ** n)) * -1 for lr, n in zip(lrs, counts, strict=True)]
        denom = torch._foreach_sqrt(exp_avg_sq)
        torch._foreach_div_(denom, [(1 - BETA2 ** n) ** 0.5 for n in counts])
        torch._foreach_add_(denom, EPS)
        update = torch._foreach_div(exp_avg, denom)
        torch._foreach_mul_(update, step_size)
        torch._foreach_add_(params, update)


class Adam:
    """Adam (β = 0.9, 0.999, ε = 1e-8) with one learning rate per parameter tensor
    (:func:`adam_update`: ``torch.optim.Adam``'s arithmetic, rounded the same on every
    CPU), without the import of ``torch._dynamo`` that the class does on first use
    (1.2–1.7 s per process here)."""

    def __init__(self, groups: list[tuple[torch.Tensor, float]]) -> None:
        self.params = [p for p, _ in groups]
        self.lrs = [lr for _, lr in groups]
        self.exp_avg = [torch.zeros_like(p, memory_format=torch.preserve_format)
                        for p in self.params]
        self.exp_avg_sq = [torch.zeros_like(p, memory_format=torch.preserve_format)
                           for p in self.params]
        # step counters on the CPU, as torch.optim.Adam keeps them: reading one is free
        self.steps = [torch.tensor(0.0, dtype=torch.float32) for _ in self.params]
        self._one = torch.tensor(1.0)

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
        """One update (:func:`adam_update`) with every learning rate scaled by ``factor``
        (the schedule), a dozen multi-tensor calls for all the tensors."""
        live = [i for i, p in enumerate(self.params) if p.grad is not None]
        if not live:
            return
        adam_update([self.params[i] for i in live],
                    [self.params[i].grad for i in live],  # type: ignore[misc]
                    [self.exp_avg[i] for i in live], [self.exp_avg_sq[i] for i in live],
                    [self.steps[i] for i in live], [self.lrs[i] * factor for i in live],
                    self._one)


def _terms(ev: Evaluation) -> dict[str, torch.Tensor]:
    """Every loss term and the total, detached 0-d tensors (no synchronisation)."""
    out = {k: v.detach() for k, v in ev.terms.items()}
    out["total"] = ev.total.detach()
    return out


def _not_finite(ev: Evaluation | None = None) -> InkmotionError:
    """The error of a non-finite loss, naming the terms of ``ev`` (the evaluation at hand,
    read from the device: the fit is ending anyway) that are not finite: some of them
    (a loss term's own fault), or all (the plan's parameters themselves)."""
    bad = [] if ev is None else [k for k, v in ev.terms.items()
                                 if not bool(torch.isfinite(v.detach()).all())]
    if ev is not None and bad and len(bad) < len(ev.terms):
        return InkmotionError(f"The optimisation produced a non-finite loss (NaN) in its "
                              f"{', '.join(bad)} term(s) alone; an image loss named there "
                              f"is at fault (check that plugin, or choose another with "
                              f"--loss).")
    why = (" (every term went non-finite: an infinite gradient, from a loss term whose "
           "gradient is unbounded, or learning rates too high, sent the plan's parameters "
           "to NaN)" if bad else "")
    return InkmotionError(f"The optimisation produced a non-finite loss (NaN){why}; lower the "
                          f"learning rates or check the input for extreme coordinates.")


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


class _Leaves:
    """One fit's parameters as the optimiser holds them: the leaves (a 3-D plan's targets
    as x, y (N, 2) and r (N, 1), module docstring), their Adam, and the plan they make."""

    def __init__(self, plans: list[MotorPlan], settings: OptimiserSettings) -> None:
        self.src = src = PlanBatch.from_plans([p.detached() for p in plans])
        self.three = three = src.points.shape[1] == 3  # radius coordinate (2.5D)
        # the shapes Ac are a leaf only when they learn (lr_ac > 0): a gradient nobody
        # uses took a fifth of the kinematics' backward (σ, μ and the onsets)
        leaves = {k: getattr(src, k).clone().requires_grad_(k != "ac" or settings.lr_ac > 0)
                  for k in ("points", "delta_t", "delta", "ac")}
        if three:
            assert settings.radius_range is not None, "a 3-D plan needs radius_range"
            del leaves["points"]
            leaves["xy"] = src.points[:, :2].clone().requires_grad_(True)  # (N, 2)
            leaves["r"] = src.points[:, 2:].clone().requires_grad_(True)  # (N, 1)
        self.leaves = leaves
        groups = ([(leaves["xy"], settings.lr_points), (leaves["r"], settings.lr_radius)]
                  if three else [(leaves["points"], settings.lr_points)])
        groups += [(leaves["delta_t"], settings.lr_delta_t), (leaves["delta"], settings.lr_delta)]
        if settings.lr_ac > 0:
            groups.append((leaves["ac"], settings.lr_ac))
        self.adam = Adam(groups)

    def load(self, resume: dict) -> None:
        """Continue from a saved ``state`` (its leaves and Adam moments)."""
        with torch.no_grad():
            for name, value in resume["leaves"].items():
                self.leaves[name].copy_(value.to(self.leaves[name].device))
        self.adam.load_state(resume["adam"])

    def points(self) -> torch.Tensor:
        """The targets (N, D); for 3-D plans [xy | r] (N, 3), a new graph from the leaves."""
        leaves = self.leaves
        return torch.cat((leaves["xy"], leaves["r"]), 1) if self.three else leaves["points"]

    def assemble(self) -> PlanBatch:
        """The batch of the current leaves."""
        src = self.src
        return PlanBatch(self.points(), self.leaves["delta_t"], self.leaves["delta"],
                         self.leaves["ac"], src.T, src.moves, src.widths)

    def clamp(self, settings: OptimiserSettings) -> None:
        """The clamps of Δt, δ, Ac (and a 3-D plan's radius), in place."""
        self.leaves["delta_t"].clamp_(*DELTA_T_RANGE)
        self.leaves["delta"].clamp_(*delta_range(settings.delta_limit))
        self.leaves["ac"].clamp_(*AC_RANGE)
        if self.three:
            self.leaves["r"].clamp_(*settings.radius_range)  # type: ignore[misc]

    def plans(self) -> list[MotorPlan]:
        """Detached copies of the current plans."""
        src = self.src
        with torch.no_grad():
            points = self.points()
        return PlanBatch(*(t.detach().clone() for t in (
            points, self.leaves["delta_t"], self.leaves["delta"], self.leaves["ac"], src.T)),
            src.moves, src.widths).to_plans()

    def state(self) -> dict:
        """Copies of the leaves and the Adam moments (``optimise``'s ``resume`` takes it)."""
        return {"leaves": {k: v.detach().clone() for k, v in self.leaves.items()},
                "adam": self.adam.state()}


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
    fit = _Leaves(plans, settings)
    first_step = 1
    if resume is not None:
        fit.load(resume)
        first_step = int(resume["step"]) + 1
    batch = fit.assemble()
    on_step = getattr(observers, "on_step", None)
    states = _StepStates(observers, plans, settings.steps)

    with torch.no_grad():
        first = objective(batch)
    initial_terms = scalars(_terms(first))
    if not math.isfinite(initial_terms["total"]):
        raise _not_finite(first)
    initial_t_end = first.t_end.tolist()
    if resume is not None and "initial_terms" in resume:  # the terms before step 1
        initial_terms, initial_t_end = resume["initial_terms"], resume["initial_t_end"]
    _restore_rng_of(resume)
    if resume is not None and resume.get("objective"):
        objective.load_state(resume["objective"])
    finite = torch.ones((), dtype=torch.bool, device=fit.src.points.device)  # all steps so far
    for step in range(first_step, settings.steps + 1):
        fit.adam.zero_grad()
        if fit.three:
            batch = fit.assemble()  # a new graph from the updated leaves
        ev = objective(batch, step)
        ev.total.backward()
        fit.adam.step(cosine(settings.schedule_start + step - 1,
                             settings.schedule_total or settings.steps, settings.lr_final))
        with torch.no_grad():
            fit.clamp(settings)
            finite = finite & torch.isfinite(ev.total.detach())
        if step % settings.check_every == 0 and not bool(finite):
            raise _not_finite(ev)
        if on_step is not None:
            on_step(states(step, ev, batch))
        if checkpoint is not None and checkpoint.due(step):  # type: ignore[attr-defined]
            checkpoint.save(step, {  # type: ignore[attr-defined]
                **fit.state(), "initial_terms": initial_terms,
                "initial_t_end": initial_t_end, "objective": objective.state()})

    with torch.no_grad():
        last = objective(fit.assemble())
    final_terms = scalars(_terms(last))
    if not bool(finite) or not math.isfinite(final_terms["total"]):
        raise _not_finite(last)
    return FitResult(
        plans=fit.plans(),
        initial_terms=initial_terms,
        final_terms=final_terms,
        initial_t_end=initial_t_end,
        final_t_end=last.t_end.tolist(),
        rendered=last.rendered.detach(),
        wall_s=time.perf_counter() - start,
        steps=settings.steps,
        state=fit.state(),
    )


def _restore_rng_of(resume: dict | None) -> None:
    """Continue the RNG streams of a checkpoint (``resume["rng"]``), after the first
    evaluation of the resumed plans: an objective with random augmentations (CLIP's)
    draws numbers there, which the uninterrupted run drew before step 1."""
    if resume is not None and resume.get("rng") is not None:
        restore_rng(resume["rng"])


@dataclass
class Request:
    """One drawing's stage in a batched fit (:func:`optimise_together`): what
    :func:`optimise` takes for it alone."""

    plans: list[MotorPlan]
    settings: OptimiserSettings
    observers: object = None
    resume: dict | None = None
    checkpoint: object = None
    #: λ times this for the stage (a rung of the tempo ladder, :mod:`~inkmotion.fitting.
    #: stages`)
    time_weight: float = 1.0


def _adam_together(fits: list[_Leaves], factor: float) -> None:
    """One Adam update of every fit (:func:`adam_update` over all their tensors: the same
    elementwise arithmetic as each fit's own update)."""
    held = [(f.adam, g) for f in fits for g, p in enumerate(f.adam.params)
            if p.grad is not None]
    if held:
        adam_update([a.params[g] for a, g in held],
                    [a.params[g].grad for a, g in held],  # type: ignore[misc]
                    [a.exp_avg[g] for a, g in held], [a.exp_avg_sq[g] for a, g in held],
                    [a.steps[g] for a, g in held], [a.lrs[g] * factor for a, g in held],
                    fits[0].adam._one)


def _clamp_together(fits: list[_Leaves], settings: OptimiserSettings) -> None:
    """:meth:`_Leaves.clamp` of every fit, one multi-tensor op per bound."""
    bounds = [("delta_t", DELTA_T_RANGE), ("delta", delta_range(settings.delta_limit)),
              ("ac", AC_RANGE)]
    if fits[0].three:
        bounds.append(("r", settings.radius_range))
    for name, (lo, hi) in bounds:
        tensors = [f.leaves[name] for f in fits]
        torch._foreach_clamp_min_(tensors, lo)
        torch._foreach_clamp_max_(tensors, hi)


def optimise_together(requests: list[Request], objective: Any) -> list[FitResult]:
    """:func:`optimise` of several drawings at once, one batched evaluation per step: the
    union of their plans through ``objective`` (a
    :class:`~inkmotion.fitting.batch_objective.BatchObjective` of their objectives, in the
    requests' order), each drawing with its own leaves, Adam moments, observers and
    checkpoint. Every request has the same step schedule (and resumes from the same step).
    Each result is what the drawing's own :func:`optimise` gives, up to float round-off
    (module :mod:`~inkmotion.fitting.batch_objective`). A NaN in any drawing raises."""
    start = time.perf_counter()
    settings = requests[0].settings
    first_step = 1 + (int(requests[0].resume["step"]) if requests[0].resume else 0)
    fits = [_Leaves(r.plans, r.settings) for r in requests]
    for fit, r in zip(fits, requests, strict=True):
        if r.resume is not None:
            fit.load(r.resume)
    src = [f.src for f in fits]
    union_t, union_moves = torch.cat([s.T for s in src]), torch.cat([s.moves for s in src])
    union_widths = torch.cat([s.widths for s in src])

    def assemble() -> PlanBatch:
        return PlanBatch(torch.cat([f.points() for f in fits]),
                         torch.cat([f.leaves["delta_t"] for f in fits]),
                         torch.cat([f.leaves["delta"] for f in fits]),
                         torch.cat([f.leaves["ac"] for f in fits]), union_t, union_moves,
                         union_widths)

    views = _ItemViews(requests, objective)
    with torch.no_grad():
        first = objective(assemble())
    initial = views.scalars(first)
    if not all(math.isfinite(t["total"]) for t in initial):
        raise _not_finite()
    initial_t_end = views.t_end(first)
    for b, r in enumerate(requests):
        if r.resume is not None and "initial_terms" in r.resume:
            initial[b], initial_t_end[b] = r.resume["initial_terms"], r.resume["initial_t_end"]
        _restore_rng_of(r.resume)
    if all(r.resume is not None and r.resume.get("objective") for r in requests):
        objective.load_item_states([r.resume["objective"] for r in requests])  # type: ignore
    finite = torch.ones(len(requests), dtype=torch.bool, device=union_t.device)
    for step in range(first_step, settings.steps + 1):
        for fit in fits:
            fit.adam.zero_grad()
        batch = assemble()
        ev = objective(batch, step)
        ev.total.sum().backward()
        _adam_together(fits, cosine(settings.schedule_start + step - 1,
                                    settings.schedule_total or settings.steps,
                                    settings.lr_final))
        with torch.no_grad():
            _clamp_together(fits, settings)
            finite = finite & torch.isfinite(ev.total.detach())
        if step % settings.check_every == 0 and not bool(finite.all()):
            raise _not_finite()
        views.observe(step, ev, batch)
        due = [b for b, r in enumerate(requests)
               if r.checkpoint is not None and r.checkpoint.due(step)]  # type: ignore
        if due:
            item_states = objective.item_states()
            for b in due:
                requests[b].checkpoint.save(step, {  # type: ignore[union-attr]
                    **fits[b].state(), "initial_terms": initial[b],
                    "initial_t_end": initial_t_end[b], "objective": item_states[b]})

    with torch.no_grad():
        last = objective(assemble())
    final = views.scalars(last)
    if not bool(finite.all()) or not all(math.isfinite(t["total"]) for t in final):
        raise _not_finite()
    wall = time.perf_counter() - start
    final_t_end = views.t_end(last)
    return [FitResult(plans=fit.plans(), initial_terms=initial[b], final_terms=final[b],
                      initial_t_end=initial_t_end[b], final_t_end=final_t_end[b],
                      rendered=views.image(last, b), wall_s=wall, steps=settings.steps,
                      state=fit.state())
            for b, fit in enumerate(fits)]


class _ItemViews:
    """Each drawing's share of a batched evaluation: its terms, T_end, image and samples,
    and its observers' step states."""

    def __init__(self, requests: list[Request], objective: Any) -> None:
        self.sizes = [(o.height, o.width) for o in objective.items]
        paths = [len(r.plans) for r in requests]
        self.path_ranges = _ranges(paths)
        self.point_ranges = _ranges([sum(p.m + 1 for p in r.plans) for r in requests])
        k = objective.p.samples_per_move
        self.sample_ranges = _ranges([sum(k * p.m + 1 for p in r.plans) for r in requests])
        self.requests = requests
        self.states = [_StepStates(r.observers, r.plans, r.settings.steps)
                       if getattr(r.observers, "on_step", None) is not None else None
                       for r in requests]

    def scalars(self, ev: Evaluation) -> list[dict[str, float]]:
        """Each drawing's terms and total as floats (one read of each term)."""
        columns = {k: v.tolist() for k, v in _terms(ev).items()}
        return [{k: v[b] for k, v in columns.items()} for b in range(len(self.requests))]

    def t_end(self, ev: Evaluation) -> list[list[float]]:
        values = ev.t_end.tolist()
        return [values[a:z] for a, z in self.path_ranges]

    def image(self, ev: Evaluation, b: int) -> torch.Tensor:
        h, w = self.sizes[b]
        return ev.rendered[b, :h, :w].detach()

    def observe(self, step: int, ev: Evaluation, batch: PlanBatch) -> None:
        """Each drawing's observers see its own step state (built only for those that
        observe; the heavy data only where they ask)."""
        for b, states in enumerate(self.states):
            if states is None:
                continue
            (pa, pz), (sa, sz), (ta, tz) = (self.path_ranges[b], self.sample_ranges[b],
                                            self.point_ranges[b])
            h, w = self.sizes[b]
            mine = Evaluation(ev.total[b], {k: v[b] for k, v in ev.terms.items()},
                              ev.t_end[pa:pz], ev.rendered[b, :h, :w], ev.positions[sa:sz],
                              ev.velocities[sa:sz])
            item_batch = PlanBatch(batch.points[ta:tz], batch.delta_t, batch.delta, batch.ac,
                                   batch.T, batch.moves, batch.widths)
            self.requests[b].observers.on_step(states(step, mine, item_batch))  # type: ignore


def _ranges(counts: list[int]) -> list[tuple[int, int]]:
    """[(start, end)] of consecutive blocks of ``counts``."""
    out, at = [], 0
    for n in counts:
        out.append((at, at + n))
        at += n
    return out
