"""Loss terms of the compound objective λ·L_smooth + w_I·L_I (+ a canvas term).

L_smooth = T_end/m + w_σ·Var[Δt]  per path (paper § Results; T_end normalised by m so λ
does not depend on the number of targets), averaged over paths: the authors'
form (``over="path"``). ``over="drawing"`` normalises the drawing's total time by its total
number of sub-movements instead, Σ_p T_end_p / Σ_p m_p + w_σ·mean_p Var(Δt_p): every
overlap Δt_i then feels the same pull T_i/M towards a shorter drawing, where the per-path
form weighs a path's overlaps by 1/(P·m_p), so the long strokes of a tag with a few
one-move flicks were hardly shortened (49873.json: T_end 0.60× against 0.52×).

The floor barrier (``w_floor``) keeps each overlap off its clamp floor from inside: a
term w_floor·B(g) per overlap i ≥ 2, normalised as T_end is, g = gap_i − floor + ε with
gap_i the nearer of what the overlap sets apart in units of T_i: the windows' openings
(Δt_i) and the two lognormals' speed peaks (:func:`overlap_gaps`). It is 0 above
``FLOOR_BAND`` and, below it, B(g) = band/g − 1 + ln(g/band) (B = B′ = 0 at the band's
edge, B′(g) = (g − band)/g² → −∞ as g → 0): against the minimum-time pull T_i alone an
overlap settles where T_i·g² + w_floor·g = w_floor·band, whatever λ is (the barrier is
divided as T_end is and weighed by the same λ): at w_floor = 0.0064 and T_i = 0.8,
g = 0.016, Δt 0.015 above the floor. It matters where the shapes Ac learn
(``--lr-ac``): a skewed lognormal does most of its movement early in its ±3σ window, so
the time cost could slide the next window's opening onto the floor while the peaks
stayed apart, or, a symmetric one before a skewed one, bring the peaks together (or past
each other) while the windows stayed apart. Where neighbours share a shape the two gaps
are one, Δt_i: the authors' floor.

A fit that edits its plan divides T_end by the *initial* plan's counts (``time_moves``):
with the plan's own m, each target an edit adds would make a second of motion cheaper
(6 → 8 targets: a quarter less pull towards a shorter motion), and the edited motions
came out slower than the plans they grew from.
"""

from __future__ import annotations

import torch

from inkmotion.scalar_tensors import scalar_tensors
from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch
from inkmotion.sigma_lognormal.params import DELTA_T_RANGE, sigma_mu

#: the gap Δt − floor below which the floor barrier acts (Δt's units: a share of T_i)
FLOOR_BAND = 0.05
#: added to the gap in the barrier, so an overlap on its floor feels a finite push off it
FLOOR_EPSILON = 1e-3


def overlap_gaps(batch: PlanBatch) -> torch.Tensor:
    """(M,) each overlap's gap in units of T_i: the nearer of the two openings it sets apart,
    its window's (Δt_i) and its speed peak's, Δt_i + (lead_i − lead_{i−1})/T_i with
    lead = e^{μ−σ²} − e^{μ−3σ} the time from a window's opening to its lognormal's mode.
    Where neighbours share a shape Ac (and T) the leads cancel exactly and the gap is Δt_i;
    where they differ, a skewed sub-movement after a symmetric one may peak before it
    although its window opens later. Entries of each path's first sub-movement are
    meaningless (callers mask them)."""
    sigma, mu = sigma_mu(batch.ac, batch.T)
    lead = torch.exp(mu - sigma * sigma) - torch.exp(mu - scalar_tensors(mu, 3.0)[0] * sigma)
    before = torch.cat([lead[:1], lead[:-1]])
    return torch.minimum(batch.delta_t, batch.delta_t + (lead - before) / batch.T)


def floor_barrier(gap: torch.Tensor, used: torch.Tensor) -> torch.Tensor:
    """(M,) B(g) of each overlap's ``gap`` (:func:`overlap_gaps`; module docstring),
    g = gap − floor + :data:`FLOOR_EPSILON`, continued below g = ε along its tangent (a
    peak gap may cross the floor: the push off it stays finite and strong); 0 where
    ``used`` is 0 (each path's Δt_1)."""
    floor, band, eps = scalar_tensors(gap, DELTA_T_RANGE[0], FLOOR_BAND, FLOOR_EPSILON)
    g = gap - floor + eps
    inside = g < band
    at = torch.where(inside, g.clamp_min(eps), band)  # where the formula is taken: finite
    b = band / at - 1 + torch.log(at / band) + (at - band) / (at * at) * (g - at)
    return torch.where(inside, b, 0.0) * used


def _with_barrier(batch: PlanBatch, t_end: torch.Tensor, used: torch.Tensor,
                  path: torch.Tensor, w_floor: float) -> torch.Tensor:
    """(P,) each path's T_end plus w_floor × its overlaps' floor barrier (one normaliser
    for both); ``t_end`` itself where ``w_floor`` is 0."""
    if w_floor <= 0:
        return t_end
    barrier = floor_barrier(overlap_gaps(batch), used)
    return t_end + scalar_tensors(t_end, w_floor)[0] * torch.zeros_like(t_end).index_add(
        0, path, barrier)


def smoothing_cost(batch: PlanBatch, t_end: torch.Tensor, w_sigma: float = 50.0,
                   layout: GridLayout | None = None, over: str = "path",
                   time_moves: torch.Tensor | None = None, w_floor: float = 0.0
                   ) -> torch.Tensor:
    """Mean over paths of T_end_p/m_p + w_σ·Var(Δt_p), Var over Δt_2..Δt_m (Δt_1 is unused)
    (``over="path"``), or Σ T_end_p / Σ m_p + w_σ·mean_p Var(Δt_p) (``over="drawing"``),
    or Σ T_end_p / Σ m_p + w_σ·Var over all the drawing's Δt (``over="pooled"``).

    ``time_moves`` (P,): the counts m_p that divide T_end_p, when they are not the plan's
    own (a fit's initial plan: :class:`~inkmotion.fitting.objective.Objective`'s
    ``time_moves``, so the targets an edit adds do not make time cheaper). ``w_floor``:
    the floor barrier's weight (module docstring; 0: none), its terms divided as the
    T_end of their path are. The variance is
    the population variance, computed for all paths at once with segment sums over
    ``layout.move_path`` (no Python loop over paths, static shapes).
    """
    layout = layout or batch.layout()
    m = layout.moves.to(t_end.dtype)  # (P,)
    per_time = m if time_moves is None else time_moves.to(t_end.dtype)  # (P,)
    path = layout.move_path  # (M,)
    used = (~layout.first).to(t_end.dtype)  # (M,) Δt_i that set an onset
    weight = scalar_tensors(t_end, w_sigma)[0]  # the same bits as w_σ, fewer casts
    spent = _with_barrier(batch, t_end, used, path, w_floor)
    if over == "pooled":  # one overlap rhythm over the whole drawing
        n_used = used.sum().clamp(min=1.0)
        mean_all = (batch.delta_t * used).sum() / n_used
        dev_all = (batch.delta_t - mean_all) * used
        return spent.sum() / per_time.sum() + weight * (dev_all * dev_all).sum() / n_used
    denom = (m - 1.0).clamp(min=1.0)  # (P,) m_p − 1 of them
    mean = torch.zeros_like(m).index_add(0, path, batch.delta_t * used) / denom
    dev = (batch.delta_t - mean[path]) * used
    var = torch.zeros_like(m).index_add(0, path, dev * dev) / denom
    if over == "drawing":
        return spent.sum() / per_time.sum() + weight * var.mean()
    assert over == "path", over
    return (spent / per_time + weight * var).mean()


def canvas_cost(points: torch.Tensor, width: float, height: float) -> torch.Tensor:
    """Mean squared distance (px²) of virtual targets outside the canvas [0, W] × [0, H]:
    each coordinate's distance to its clamp into the canvas (0 inside)."""
    xy = points[:, :2]
    inside = torch.stack((xy[:, 0].clamp(0, width), xy[:, 1].clamp(0, height)), 1)
    return (xy - inside).square().sum(1).mean()


def smoothing_costs(batch: PlanBatch, t_end: torch.Tensor, w_sigma: float, layout: GridLayout,
                    over: str, path_item: torch.Tensor, items: int,
                    time_moves: torch.Tensor | None = None, w_floor: float = 0.0
                    ) -> torch.Tensor:
    """:func:`smoothing_cost` of each of ``items`` drawings fitted together (items,): path p
    belongs to drawing ``path_item[p]``, and each drawing's cost is its own paths' (a batched
    fit: the same value as the drawing's own fit, up to float round-off); ``time_moves``
    (P,) and ``w_floor`` as there."""
    m = layout.moves.to(t_end.dtype)  # (P,)
    per_time = m if time_moves is None else time_moves.to(t_end.dtype)  # (P,)
    path = layout.move_path  # (M,)
    move_item = path_item[path]  # (M,)
    used = (~layout.first).to(t_end.dtype)  # (M,)
    zeros = t_end.new_zeros(items)
    t_end = _with_barrier(batch, t_end, used, path, w_floor)
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
