"""Several drawings' objectives evaluated as one: the forward pass of a batched fit.

A fit is bound by the cost of launching its ops (about a thousand small ones per step), not
by their arithmetic, so B drawings fitted side by side in one optimisation cost little more
per step than one. The batch's plans are the union of every drawing's paths (one
:class:`~inkmotion.sigma_lognormal.batch.PlanBatch`): one ΣΛ kinematics call, one set of
Hermite Bézier segments, one renderer call drawing each drawing on its own canvas
(:class:`~inkmotion.rendering.raster.Canvases`), and each term of
:class:`~inkmotion.fitting.objective.Objective` computed per drawing in one op each (the
image losses stacked where the loss offers it, the smoothing and canvas costs by
per-drawing sums, the trace terms joined by :meth:`~inkmotion.fitting.trace_loss.TraceLoss.
union`). The evaluation's ``total`` is each drawing's own total (B,): its gradient w.r.t. a
drawing's parameters is that drawing's alone, so Adam, being elementwise, takes the steps
each drawing's own fit would take, up to float round-off (the sums are ordered otherwise).
"""

from __future__ import annotations

from typing import Any

import torch

from inkmotion.fitting.losses import canvas_costs, smoothing_costs
from inkmotion.fitting.objective import Evaluation, Objective
from inkmotion.sigma_lognormal.batch import PlanBatch


def can_batch(objectives: list[Objective]) -> bool:
    """Whether these drawings' objectives can be evaluated as one: the same renderer (one
    that draws several canvases per call), weights, image losses and canvas scale."""
    first = objectives[0]
    renderer = first.renderer
    if not getattr(renderer, "renders_canvases", False):
        return False
    return all(o.renderer is renderer and o.p == first.p
               and list(o.image_losses) == list(first.image_losses)
               and (o.trace is None) == (first.trace is None)
               and (o.time_moves is None) == (first.time_moves is None)
               and max(o.width, o.height) == max(first.width, first.height)
               for o in objectives)


class BatchObjective(Objective):
    """Σ over drawings of their :class:`Objective` (module docstring); ``objectives[b]``
    owns the next ``path_counts[b]`` paths of the batches it is called with."""

    def __init__(self, objectives: list[Objective], path_counts: list[int]) -> None:
        first = objectives[0]
        super().__init__(first.renderer, {}, (max(o.width for o in objectives),
                                              max(o.height for o in objectives)),
                         first.p, static=first.static, check_every=first.check_every,
                         time_moves=None if first.time_moves is None else
                         [m for o in objectives for m in o.time_moves or ()])
        self.items = objectives
        self.path_counts = path_counts
        self.count = len(objectives)
        self.losses = {name: self._stacked([o.image_losses[name] for o in objectives])
                       for name in first.image_losses}
        self.trace_union = None
        if first.trace is not None:
            from inkmotion.fitting.trace_loss import TraceLoss

            self.trace_union = TraceLoss.union([o.trace for o in objectives],  # type: ignore
                                               path_counts)
        self._index: dict[str, Any] | None = None

    def _stacked(self, fns: list[Any]) -> Any:
        """One loss of the drawings' images (B, H, W) -> (B,): the loss's own stacked form
        when it has one, else each drawing's loss of its own canvas."""
        stack = getattr(fns[0], "stack", None)
        if stack is not None and all(getattr(f, "stack", None) is stack for f in fns):
            return stack(fns, self.height, self.width)
        sizes = [(o.height, o.width) for o in self.items]

        def each(rendered: torch.Tensor) -> torch.Tensor:
            return torch.stack([fn(rendered[b, :h, :w])
                                for b, (fn, (h, w)) in enumerate(zip(fns, sizes, strict=True))])
        return each

    def _indices(self, batch: PlanBatch) -> dict[str, Any]:
        """Which drawing each path, target and segment belongs to, on the batch's device."""
        if self._index is None:
            from inkmotion.rendering.raster import Canvases

            device = batch.points.device
            counts = torch.as_tensor(self.path_counts, device=device)
            path_item = torch.repeat_interleave(torch.arange(self.count, device=device), counts)
            layout = self._layout(batch)
            sizes = torch.as_tensor([[o.width, o.height] for o in self.items], device=device)
            point_item = torch.repeat_interleave(path_item, layout.moves + 1)
            self._index = {"path_item": path_item, "point_item": point_item, "sizes": sizes,
                           "canvases": Canvases(path_item[layout.segment_path], sizes,
                                                self.count)}
        return self._index

    def __call__(self, batch: PlanBatch, step: int | None = None) -> Evaluation:
        """The drawings' forward passes at once: ``total`` and every term (B,), ``rendered``
        (B, H, W) (drawing b in its top-left h_b × w_b corner)."""
        index = self._indices(batch)
        layout, t_end, kin, segments = self._motion(batch)
        rendered = self._draw(segments, batch.widths[layout.segment_path], index["canvases"])
        terms: dict[str, torch.Tensor] = {}
        image = rendered.new_zeros(self.count)
        for name, fn in self.losses.items():
            terms[name] = fn(rendered)
            image = image + terms[name]
        terms["smooth"] = smoothing_costs(batch, t_end, self.p.w_sigma, layout,
                                          self.p.smooth_over, index["path_item"], self.count,
                                          self._time_moves_on(batch), self.p.w_floor)
        terms["canvas"] = canvas_costs(batch.points, index["point_item"], index["sizes"],
                                       self.count)
        if self.trace_union is not None:
            terms["trace"] = self.trace_union(segments, layout, step)
        return Evaluation(self.weighted(terms, image), terms, t_end, rendered, kin.positions,
                          kin.velocities)

    def item_states(self) -> list[dict]:
        """Each drawing's :meth:`Objective.state` (for its own checkpoint)."""
        if self.trace_union is None:
            return [{} for _ in self.items]
        return [{"trace": s} for s in self.trace_union.item_states()]

    def load_item_states(self, states: list[dict | None]) -> None:
        """Continue with each drawing's own saved state (after the first evaluation)."""
        if self.trace_union is not None and all(s and s.get("trace") for s in states):
            self.trace_union.load_item_states([s["trace"] for s in states])  # type: ignore
