"""Loss terms of the compound objective λ·L_smooth + w_I·L_I (+ a canvas term).

L_smooth = T_end/m + w_σ·Var[Δt]  per path (paper § Results; T_end normalised by m so λ
does not depend on the number of targets), averaged over paths: the authors'
form (``over="path"``). ``over="drawing"`` normalises the drawing's total time by its total
number of sub-movements instead, Σ_p T_end_p / Σ_p m_p + w_σ·mean_p Var(Δt_p): every
overlap Δt_i then feels the same pull T_i/M towards a shorter drawing, where the per-path
form weighs a path's overlaps by 1/(P·m_p), so the long strokes of a tag with a few
one-move flicks were hardly shortened (49873.json: T_end 0.60× against 0.52×).

A fit that edits its plan divides T_end by the *initial* plan's counts (``time_moves``):
with the plan's own m, each target an edit adds would make a second of motion cheaper
(6 → 8 targets: a quarter less pull towards a shorter motion), and the edited motions
came out slower than the plans they grew from.
"""

from __future__ import annotations

import torch

from inkmotion.scalar_tensors import scalar_tensors
from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch


def smoothing_cost(batch: PlanBatch, t_end: torch.Tensor, w_sigma: float = 50.0,
                   layout: GridLayout | None = None, over: str = "path",
                   time_moves: torch.Tensor | None = None) -> torch.Tensor:
    """Mean over paths of T_end_p/m_p + w_σ·Var(Δt_p), Var over Δt_2..Δt_m (Δt_1 is unused)
    (``over="path"``), or Σ T_end_p / Σ m_p + w_σ·mean_p Var(Δt_p) (``over="drawing"``),
    or Σ T_end_p / Σ m_p + w_σ·Var over all the drawing's Δt (``over="pooled"``).

    ``time_moves`` (P,): the counts m_p that divide T_end_p, when they are not the plan's
    own (a fit's initial plan: :class:`~inkmotion.fitting.objective.Objective`'s
    ``time_moves``, so the targets an edit adds do not make time cheaper). The variance is
    the population variance, computed for all paths at once with segment sums over
    ``layout.move_path`` (no Python loop over paths, static shapes).
    """
    layout = layout or batch.layout()
    m = layout.moves.to(t_end.dtype)  # (P,)
    per_time = m if time_moves is None else time_moves.to(t_end.dtype)  # (P,)
    path = layout.move_path  # (M,)
    used = (~layout.first).to(t_end.dtype)  # (M,) Δt_i that set an onset
    weight = scalar_tensors(t_end, w_sigma)[0]  # the same bits as w_σ, fewer casts
    if over == "pooled":  # one overlap rhythm over the whole drawing
        n_used = used.sum().clamp(min=1.0)
        mean_all = (batch.delta_t * used).sum() / n_used
        dev_all = (batch.delta_t - mean_all) * used
        return t_end.sum() / per_time.sum() + weight * (dev_all * dev_all).sum() / n_used
    denom = (m - 1.0).clamp(min=1.0)  # (P,) m_p − 1 of them
    mean = torch.zeros_like(m).index_add(0, path, batch.delta_t * used) / denom
    dev = (batch.delta_t - mean[path]) * used
    var = torch.zeros_like(m).index_add(0, path, dev * dev) / denom
    if over == "drawing":
        return t_end.sum() / per_time.sum() + weight * var.mean()
    assert over == "path", over
    return (t_end / per_time + weight * var).mean()


def canvas_cost(points: torch.Tensor, width: float, height: float) -> torch.Tensor:
    """Mean squared distance (px²) of virtual targets outside the canvas [0, W] × [0, H]:
    each coordinate's distance to its clamp into the canvas (0 inside)."""
    xy = points[:, :2]
    inside = torch.stack((xy[:, 0].clamp(0, width), xy[:, 1].clamp(0, height)), 1)
    return (xy - inside).square().sum(1).mean()


def smoothing_costs(batch: PlanBatch, t_end: torch.Tensor, w_sigma: float, layout: GridLayout,
                    over: str, path_item: torch.Tensor, items: int,
                    time_moves: torch.Tensor | None = None) -> torch.Tensor:
    """:func:`smoothing_cost` of each of ``items`` drawings fitted together (items,): path p
    belongs to drawing ``path_item[p]``, and each drawing's cost is its own paths' (a batched
    fit: the same value as the drawing's own fit, up to float round-off); ``time_moves``
    (P,) as there."""
    m = layout.moves.to(t_end.dtype)  # (P,)
    per_time = m if time_moves is None else time_moves.to(t_end.dtype)  # (P,)
    path = layout.move_path  # (M,)
    move_item = path_item[path]  # (M,)
    used = (~layout.first).to(t_end.dtype)  # (M,)
    zeros = t_end.new_zeros(items)
    if over == "pooled":
        n_used = zeros.index_add(0, move_item, used).clamp(min=1.0)
        mean = zeros.index_add(0, move_item, batch.delta_t * used) / n_used
        dev = (batch.delta_t - mean[move_item]) * used
        var = zeros.index_add(0, move_item, dev * dev) / n_used
        return (zeros.index_add(0, path_item, t_end) / zeros.index_add(0, path_item, per_time)
                + w_sigma * var)
    denom = (m - 1.0).clamp(min=1.0)  # (P,)
    mean = torch.zeros_like(m).index_add(0, path, batch.delta_t * used) / denom
    dev = (batch.delta_t - mean[path]) * used
    var = torch.zeros_like(m).index_add(0, path, dev * dev) / denom  # (P,)
    paths = zeros.index_add(0, path_item, torch.ones_like(m))
    if over == "drawing":
        return (zeros.index_add(0, path_item, t_end) / zeros.index_add(0, path_item, per_time)
                + w_sigma * zeros.index_add(0, path_item, var) / paths)
    assert over == "path", over
    return zeros.index_add(0, path_item, t_end / per_time + w_sigma * var) / paths


def canvas_costs(points: torch.Tensor, point_item: torch.Tensor, sizes: torch.Tensor,
                 items: int) -> torch.Tensor:
    """:func:`canvas_cost` of each of ``items`` drawings (items,): target i belongs to
    drawing ``point_item[i]``, whose canvas is ``sizes[point_item[i]]`` = (W, H)."""
    limit = sizes.to(points.dtype)[point_item]  # (N, 2)
    x, y = points[:, 0], points[:, 1]
    out = (torch.relu(-x) ** 2 + torch.relu(x - limit[:, 0]) ** 2
           + torch.relu(-y) ** 2 + torch.relu(y - limit[:, 1]) ** 2)
    zeros = out.new_zeros(items)
    return zeros.index_add(0, point_item, out) / zeros.index_add(0, point_item,
                                                                   torch.ones_like(out))
