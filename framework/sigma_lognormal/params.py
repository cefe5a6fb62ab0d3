"""ΣΛ timing parameters from the optimisable reparametrisation (the paper's, errata applied).

σ_i = sqrt(−ln(1 − Ac_i)),  μ_i = 3σ_i − ln((e^{6σ_i} − 1) / T_i)
so that the ±3σ window of each lognormal lasts exactly T_i: e^{μ+3σ} − e^{μ−3σ} = T_i.

Onsets follow the authors' implementation (the paper's text prints Δt·sinh(3σ)):
t0_1 = −e^{μ_1 − 3σ_1} (the first window starts at t = 0), t0_i = t0_{i−1} + Δt_i·T_i.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import torch

from inkmotion.portable_math import expm1, log1p
from inkmotion.scalar_tensors import scalar_tensors

#: the optimiser's clamps (the authors' defaults); the renderer and kinematics plan
#: their static sizes from the same bounds
DELTA_T_RANGE = (0.1, 0.9)
#: the authors' clamp of the turning angle δ: a quarter circle. A fit's own clamp is its
#: ``max_turn`` (:class:`inkmotion.kinds.optimisation.OptimisationParams`,
#: :func:`delta_range`)
DELTA_RANGE = (-math.pi / 2, math.pi / 2)
AC_RANGE = (1e-4, 0.1)


def delta_range(limit: float) -> tuple[float, float]:
    """The clamp (−limit, limit) of the turning angles δ, ``limit`` in radians."""
    return (-limit, limit)

if TYPE_CHECKING:
    from inkmotion.sigma_lognormal.batch import GridLayout


def sigma_mu(ac: torch.Tensor, T: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Lognormal (σ, μ) from shape Ac ∈ (0, 1) and ±3σ duration T, both (M,), with
    :mod:`inkmotion.portable_math`'s ln(1 + x) and e^x − 1 (the same bits on every CPU)."""
    three, six = scalar_tensors(ac, 3.0, 6.0)
    sigma = torch.sqrt(-log1p(-ac))
    mu = three * sigma - torch.log(expm1(six * sigma) / T)
    return sigma, mu


def sigma_mu_slopes(ac: torch.Tensor, sigma: torch.Tensor
                    ) -> tuple[torch.Tensor, torch.Tensor]:
    """The slopes of :func:`sigma_mu`, for gradients written by hand: dμ/dσ = 3 −
    6e^{6σ}/(e^{6σ} − 1) (at fixed T) and dAc/dσ = 2σ(1 − Ac) (a gradient in σ divided by
    it is one in Ac), (M,) each."""
    one, two, three, six = scalar_tensors(sigma, 1.0, 2.0, 3.0, 6.0)
    return three - six * torch.exp(six * sigma) / expm1(six * sigma), two * sigma * (one - ac)


def onsets(
    delta_t: torch.Tensor,  # (M,)
    T: torch.Tensor,  # (M,)
    sigma: torch.Tensor,  # (M,)
    mu: torch.Tensor,  # (M,)
    layout: GridLayout,
) -> torch.Tensor:
    """Onset times t0 (M,) of every sub-movement of several packed paths.

    Within a path: t0_1 = −e^{μ_1−3σ_1}, t0_i = t0_{i−1} + Δt_i·T_i + (e^{μ_{i−1}−3σ_{i−1}}
    − e^{μ_i−3σ_i}) (Δt_1 unused): each ±3σ window opens Δt_i·T_i after the one before
    it. Where every Ac_i and T_i are equal (a fit's default, the authors' setting) the
    bracket is exactly 0 and this is the authors' t0_i = t0_{i−1} + Δt_i·T_i; where they
    differ (``--lr-ac``), the window opens e^{μ−3σ} after t0, 0.13 s at Ac 0.1 and 13 s at
    1e-4, and chaining the t0 alone let a window open before the previous one, or before
    t = 0. Done as one global cumulative sum, minus what was accumulated before each
    path's first entry (gathered at ``layout.move_first``): no Python loop, no
    data-dependent shape.
    """
    lead = torch.exp(mu - scalar_tensors(mu, 3.0)[0] * sigma)  # (M,) from t0 to the opening
    before = torch.cat([lead[:1], lead[:-1]])  # the previous sub-movement's (unused first)
    steps = torch.where(layout.first, -lead, delta_t * T + (before - lead))  # (M,)
    total = torch.cumsum(steps, dim=0)
    return total - (total - steps).index_select(0, layout.move_first)


def end_times(t0: torch.Tensor, sigma: torch.Tensor, mu: torch.Tensor,
              layout: GridLayout) -> torch.Tensor:
    """T_end per path (P,): t0_m + e^{μ_m + 3σ_m} of each path's last sub-movement."""
    last = layout.last_move  # (P,)
    return t0.index_select(0, last) + torch.exp(
        mu.index_select(0, last) + scalar_tensors(mu, 3.0)[0] * sigma.index_select(0, last))
