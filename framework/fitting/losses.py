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

from typing import Any

import torch

from inkmotion.scalar_tensors import scalar_tensors
from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch
from inkmotion.sigma_lognormal.params import DELTA_T_RANGE, sigma_mu, sigma_mu_slopes

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
    return _gap_parts(batch.delta_t, batch.ac, batch.T)[-1]


def _gap_parts(delta_t: torch.Tensor, ac: torch.Tensor, T: torch.Tensor
               ) -> tuple[torch.Tensor, ...]:
    """:func:`overlap_gaps` and what its gradient needs: σ, μ, e^{μ−σ²}, e^{μ−3σ}, the
    peaks' side of the minimum and the gap, (M,) each."""
    sigma, mu = sigma_mu(ac, T)
    peak = torch.exp(mu - sigma * sigma)
    opening = torch.exp(mu - scalar_tensors(mu, 3.0)[0] * sigma)
    lead = peak - opening
    before = torch.cat([lead[:1], lead[:-1]])
    peaks = delta_t + (lead - before) / T
    return sigma, mu, peak, opening, peaks, torch.minimum(delta_t, peaks)


def floor_barrier(gap: torch.Tensor, used: torch.Tensor) -> torch.Tensor:
    """(M,) B(g) of each overlap's ``gap`` (:func:`overlap_gaps`; module docstring),
    g = gap − floor + :data:`FLOOR_EPSILON`, continued below g = ε along its tangent (a
    peak gap may cross the floor: the push off it stays finite and strong); 0 where
    ``used`` is 0 (each path's Δt_1)."""
    return _barrier_parts(gap, used)[0]


def _barrier_parts(gap: torch.Tensor, used: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`floor_barrier` and its slope ∂B/∂gap (M,): (at − band)/at² inside the band
    (at = g, or ε below it, where the tangent continues), 0 beyond it and where unused."""
    floor, band, eps = scalar_tensors(gap, DELTA_T_RANGE[0], FLOOR_BAND, FLOOR_EPSILON)
    g = gap - floor + eps
    inside = g < band
    at = torch.where(inside, g.clamp_min(eps), band)  # where the formula is taken: finite
    rise = (at - band) / (at * at)
    b = band / at - 1 + torch.log(at / band) + rise * (g - at)
    return torch.where(inside, b, 0.0) * used, torch.where(inside, rise, 0.0) * used


class _FloorBarrier(torch.autograd.Function):
    """:func:`floor_barrier` of :func:`overlap_gaps` as one graph node, (Δt, Ac, T, used)
    → (M,): the forward the same ops (the same values), the gradient written out
    (autograd's graph of the two took some 190 ops a step, a twentieth of a fit's step,
    for an (M,) tensor):

        ∂B/∂gap: :func:`_barrier_parts`' slope;  ∂gap/∂Δt_i = 1 (either side of the min);
        ∂gap_i/∂(lead_i − lead_{i−1}) = 1/T_i where the peaks' side is the lesser (half
        of it at a tie, as ``torch.minimum`` shares it);
        lead = e^{μ−σ²} − e^{μ−3σ},  μ′ = dμ/dσ = 3 − 6e^{6σ}/(e^{6σ} − 1),
        dlead/dσ = e^{μ−σ²}(μ′ − 2σ) − e^{μ−3σ}(μ′ − 3),  dσ/dAc = 1/(2σ(1 − Ac)).

    T gets no gradient (a fit never learns it)."""

    @staticmethod
    def forward(ctx: Any, delta_t: torch.Tensor, ac: torch.Tensor, T: torch.Tensor,
                used: torch.Tensor) -> torch.Tensor:
        sigma, mu, peak, opening, peaks, gap = _gap_parts(delta_t, ac, T)
        barrier, slope = _barrier_parts(gap, used)
        if ctx.needs_input_grad[1]:
            half, one = scalar_tensors(delta_t, 0.5, 1.0)
            side = torch.where(peaks < delta_t, one, torch.where(peaks == delta_t, half, 0.0))
            ctx.save_for_backward(slope, side, T, ac, sigma, peak, opening)
        else:
            ctx.save_for_backward(slope)
        return barrier

    @staticmethod
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        g_gap = grad * ctx.saved_tensors[0]
        g_ac = None
        if ctx.needs_input_grad[1]:
            _, side, T, ac, sigma, peak, opening = ctx.saved_tensors
            two, three = scalar_tensors(grad, 2.0, 3.0)
            g_rise = g_gap * side / T  # ∂/∂(lead_i − lead_{i−1})
            # lead_i is sub-movement i+1's ``before``, and lead_0 its own
            g_lead = g_rise - torch.cat([g_rise[1:], g_rise.new_zeros(1)])
            g_lead = torch.cat([g_lead[:1] - g_rise[:1], g_lead[1:]])
            dmu, dac = sigma_mu_slopes(ac, sigma)
            dlead = peak * (dmu - two * sigma) - opening * (dmu - three)
            g_ac = g_lead * dlead / dac
        return (g_gap if ctx.needs_input_grad[0] else None), g_ac, None, None


def _with_barrier(batch: PlanBatch, t_end: torch.Tensor, used: torch.Tensor,
                  path: torch.Tensor, w_floor: float) -> torch.Tensor:
    """(P,) each path's T_end plus w_floor × its overlaps' floor barrier (one normaliser
    for both); ``t_end`` itself where ``w_floor`` is 0."""
    if w_floor <= 0:
        return t_end
    if batch.T.requires_grad:  # a graph through T too (no fit learns it): autograd's
        barrier = floor_barrier(overlap_gaps(batch), used)
    else:
        barrier = _FloorBarrier.apply(batch.delta_t, batch.ac, batch.T, used)
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
