"""The compound objective of a fit: λ·L_smooth + w_I·Σ L_I + w_c·canvas term.

One evaluation is the hot loop's forward pass: ΣΛ kinematics on the fitting grid
(n_p = samples_per_move·m_p) → Hermite Bézier segments (S, 4, D), a 3-D plan's radius
included → render → image losses, plus the smoothing cost (the authors' defaults)
and a term keeping targets on the canvas.

No host synchronisation: the grid's index structure (a
:class:`~inkmotion.sigma_lognormal.batch.GridLayout`) is built on the first call, with a
static kinematics window (wide enough for any plan within the optimiser's clamps) and the
renderer's static budgets where ``static``; a non-finite total is returned as such (the
optimiser checks it every few steps), and a window or budget that is (nearly) outgrown
raises a flag on the device, read every ``check_every`` calls (or by
:meth:`Objective.replan_if_needed`), after which they are planned again.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import torch

from inkmotion.errors import InkmotionError
from inkmotion.fitting.losses import canvas_cost, smoothing_cost
from inkmotion.geometry.bezier import hermite_segments
from inkmotion.plugin_host.protocols import BoundLoss, Renderer, RenderFunction
from inkmotion.scalar_tensors import scalar_tensors
from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch
from inkmotion.sigma_lognormal.kinematics import evaluate_kinematics, grid_timing, plan_window
from inkmotion.sigma_lognormal.params import AC_RANGE, DELTA_T_RANGE

#: the optimiser's clamps Δt ≥ 0.1 and Ac ≤ 0.1 (the authors' defaults): a static
#: kinematics window is planned wide enough for any plan within them
DELTA_T_MIN = DELTA_T_RANGE[0]
AC_MAX = AC_RANGE[1]

#: (segments (S, 4, D), layout, step) -> 0-d loss: the trace term
#: (:class:`inkmotion.fitting.trace_loss.TraceLoss`, with ``state``/``load_state``)
TraceTerm = Callable[[torch.Tensor, GridLayout, "int | None"], torch.Tensor]


@dataclass(frozen=True)
class Weights:
    """Weights of the compound objective. No defaults here: a job kind's parameters hold
    them (:class:`inkmotion.kinds.optimisation.OptimisationParams`)."""

    lambda_smooth: float
    w_image: float
    w_sigma: float
    w_canvas: float
    samples_per_move: int
    smooth_over: str  # "path" (the authors'), "drawing" or "pooled", see fitting.losses
    w_trace: float  # weight of the trace term (fitting.trace_loss), when there is one
    w_floor: float  # weight of the overlaps' floor barrier in L_smooth (fitting.losses)


@dataclass
class Evaluation:
    """One forward pass: the loss terms and what the observers may want to see."""

    total: torch.Tensor
    terms: dict[str, torch.Tensor]
    t_end: torch.Tensor  # (P,)
    rendered: torch.Tensor  # (H, W)
    positions: torch.Tensor  # (N, D)
    velocities: torch.Tensor  # (N, D)


class Objective:
    """λ·mean_p(T_end/m + w_σ·VarΔt) + w_I·Σ image losses + w_c·canvas term
    (+ w_trace·L_trace when the input's trace is known: ``trace``).

    ``static``: static shapes and no device read in a call (None: on any device but the
    CPU, where reading the device is free and sizing per call does less work).
    ``check_every``: read the "no longer fits" flags every that many calls (0: only when
    :meth:`replan_if_needed` is called, e.g. by the optimiser with its own checks).
    ``time_moves``: the sub-movements of each path that divide its T_end in L_smooth, fixed
    for the whole fit (a fit passes its initial plan's, so plan edits do not weaken the
    pull towards a rapid motion); None: each evaluated plan's own.
    """

    def __init__(self, renderer: Renderer, image_losses: dict[str, BoundLoss],
                 canvas: tuple[int, int], weights: Weights, *, static: bool | None = None,
                 check_every: int = 25, trace: TraceTerm | None = None,
                 time_moves: Sequence[int] | None = None) -> None:
        self.renderer = renderer
        self.trace = trace
        self.time_moves = None if time_moves is None else tuple(int(m) for m in time_moves)
        self._time_moves: torch.Tensor | None = None  # time_moves on the plans' device
        self.image_losses = image_losses
        self.width, self.height = canvas
        self.p = weights
        self.static = static
        self.check_every = check_every
        self.layout: GridLayout | None = None
        self._render: RenderFunction | None = None  # the renderer, or its session
        self._window_overflow: torch.Tensor | None = None  # 0-d bool on the device
        self._calls = 0

    def __call__(self, batch: PlanBatch, step: int | None = None) -> Evaluation:
        """One forward pass; ``step`` is the optimiser's (1-based) step, None for an
        evaluation outside the loop (terms with state, the trace term, keep theirs)."""
        layout, t_end, kin, segments = self._motion(batch)
        rendered = self._draw(segments, batch.widths.index_select(0, layout.segment_path))
        terms: dict[str, torch.Tensor] = {}
        image = rendered.new_zeros(())
        for name, fn in self.image_losses.items():
            terms[name] = fn(rendered)
            image = image + terms[name]
        terms["smooth"] = smoothing_cost(batch, t_end, self.p.w_sigma, layout,
                                         self.p.smooth_over, self._time_moves_on(batch),
                                         self.p.w_floor)
        terms["canvas"] = canvas_cost(batch.points, self.width, self.height)
        if self.trace is not None:
            terms["trace"] = self.trace(segments, layout, step)
        return Evaluation(self.weighted(terms, image), terms, t_end, rendered, kin.positions,
                          kin.velocities)

    def weighted(self, terms: dict[str, torch.Tensor], image: torch.Tensor) -> torch.Tensor:
        """λ·L_smooth + w_I·Σ L_I + w_c·canvas term (+ w_trace·L_trace when ``terms`` has
        it), from the terms and the image losses' sum ``image``."""
        lam, w_image, w_canvas, w_trace = scalar_tensors(
            image, self.p.lambda_smooth, self.p.w_image, self.p.w_canvas, self.p.w_trace)
        total = lam * terms["smooth"] + w_image * image + w_canvas * terms["canvas"]
        if "trace" in terms:
            total = total + w_trace * terms["trace"]
        return total

    def _motion(self, batch: PlanBatch) -> tuple[GridLayout, torch.Tensor, Any, torch.Tensor]:
        """The forward pass up to the image: the grid's layout, T_end (P,), the kinematics
        and the Hermite Bézier segments (S, 4, D) (a 3-D plan's radius included: the
        renderer then ignores the widths, the Renderer protocol)."""
        self._calls += 1
        if self.check_every and self._calls % self.check_every == 0:
            self.replan_if_needed()
        layout = self._layout(batch)
        # σ, μ, t0 and the grid: one graph node for T_end and the kinematics
        timing, times, dt = grid_timing(batch, layout)
        if layout.window is None and self._static(batch):
            layout = self.layout = plan_window(batch, times, layout, min_delta_t=DELTA_T_MIN,
                                               max_ac=AC_MAX)
        t_end = times.index_select(0, layout.block_end - 1)  # (P,) the last sample is T_end
        kin, overflow = evaluate_kinematics(batch, times, layout, accelerations=False,
                                            timing=timing)
        if overflow is not None:
            self._window_overflow = overflow if self._window_overflow is None \
                else self._window_overflow | overflow
        segments = hermite_segments(kin.positions, kin.velocities, layout, dt)
        return layout, t_end, kin, segments

    def _time_moves_on(self, batch: PlanBatch) -> torch.Tensor | None:
        """``time_moves`` as a tensor of the plans' dtype on their device (made once), or
        None."""
        if self.time_moves is None:
            return None
        kept = self._time_moves
        if kept is None or kept.device != batch.points.device \
                or kept.dtype != batch.points.dtype:
            if len(self.time_moves) != int(batch.moves.shape[0]):
                raise ValueError(f"time_moves has {len(self.time_moves)} paths, the plans "
                                 f"{int(batch.moves.shape[0])}")
            kept = self._time_moves = torch.as_tensor(
                self.time_moves, dtype=batch.points.dtype, device=batch.points.device)
        return kept

    def state(self) -> dict:
        """The state of the objective's terms that a resumed fit needs (a checkpoint)."""
        fn = getattr(self.trace, "state", None)
        return {"trace": fn()} if fn is not None else {}

    def load_state(self, state: dict) -> None:
        """Continue with :meth:`state`'s copy (after a first evaluation of the batch)."""
        fn = getattr(self.trace, "load_state", None)
        if fn is not None and state.get("trace") is not None:
            fn(state["trace"])

    def replan_if_needed(self) -> bool:
        """Read (once) the device flags saying the kinematics window or the renderer's budget
        was (nearly) outgrown since the last check; if so, they are planned again on the next
        call. True when something is replanned."""
        session_flag = getattr(self._render, "overflow", None)
        flags = [f for f in (self._window_overflow, session_flag) if f is not None]
        if not flags or not bool(torch.stack(flags).any()):
            return False
        if self._window_overflow is not None and bool(self._window_overflow):
            self.layout = self.layout.with_window(None) if self.layout is not None else None
        self._window_overflow = None
        replan = getattr(self._render, "replan_if_needed", None)
        if replan is not None:
            replan()
        return True

    def _static(self, batch: PlanBatch) -> bool:
        return self.static if self.static is not None else batch.points.device.type != "cpu"

    def _layout(self, batch: PlanBatch) -> GridLayout:
        """The grid's layout, built when the first batch (or one with other ``moves``) comes."""
        if self.layout is None or self.layout.moves is not batch.moves:
            self.layout = batch.layout(samples_per_move=self.p.samples_per_move)
            self._window_overflow = None
        return self.layout

    def _draw(self, segments: torch.Tensor, widths: torch.Tensor,
              canvases: Any = None) -> torch.Tensor:
        """Render (H, W) with the renderer's per-fit session when it offers one; several
        drawings (count, H, W) with ``canvases`` (a renderer that ``renders_canvases``)."""
        if self._render is None:
            session = getattr(self.renderer, "session", None)
            self._render = self.renderer if session is None else \
                session(segments.device, static=self.static)
        try:
            if canvases is not None:
                return self._render(segments, widths, self.height, self.width,
                                    canvases=canvases)
            return self._render(segments, widths, self.height, self.width)
        except ValueError as exc:  # bad shapes; values are not checked (no device read)
            raise InkmotionError(f"The renderer refused the trajectory ({exc}); lower the "
                                 "learning rates or check the input.") from exc
