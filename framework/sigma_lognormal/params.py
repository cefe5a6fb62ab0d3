"""ΣΛ timing parameters from the optimisable reparametrisation (DESIGN.md, errata applied).

σ_i = sqrt(−ln(1 − Ac_i)),  μ_i = 3σ_i − ln((e^{6σ_i} − 1) / T_i)
so that the ±3σ window of each lognormal lasts exactly T_i: e^{μ+3σ} − e^{μ−3σ} = T_i.

Onsets follow the authors' implementation (the paper's text prints Δt·sinh(3σ)):
t0_1 = −e^{μ_1 − 3σ_1} (the first window starts at t = 0), t0_i = t0_{i−1} + Δt_i·T_i.
"""

from __future__ import annotations

import torch


def sigma_mu(ac: torch.Tensor, T: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Lognormal (σ, μ) from shape Ac ∈ (0, 1) and ±3σ duration T, both (M,)."""
    sigma = torch.sqrt(-torch.log1p(-ac))
    mu = 3.0 * sigma - torch.log(torch.expm1(6.0 * sigma) / T)
    return sigma, mu


def onsets(
    delta_t: torch.Tensor,  # (M,)
    T: torch.Tensor,  # (M,)
    sigma: torch.Tensor,  # (M,)
    mu: torch.Tensor,  # (M,)
    first: torch.Tensor,  # (M,) bool: first sub-movement of its path
) -> torch.Tensor:
    """Onset times t0 (M,) of every sub-movement of several packed paths.

    Within a path: t0_1 = −e^{μ_1−3σ_1}, t0_i = t0_{i−1} + Δt_i·T_i (Δt_1 unused). Done as
    one global cumulative sum with a reset at each path's first entry, no Python loop.
    """
    start = -torch.exp(mu - 3.0 * sigma)
    steps = torch.where(first, start, delta_t * T)  # (M,)
    total = torch.cumsum(steps, dim=0)
    # subtract everything accumulated before each path's first entry
    before = (total - steps) * first  # (M,) nonzero only at path starts
    path_id = torch.cumsum(first.long(), dim=0) - 1
    first_idx = torch.nonzero(first).squeeze(1)
    return total - before[first_idx][path_id]


def end_times(t0: torch.Tensor, sigma: torch.Tensor, mu: torch.Tensor,
              last: torch.Tensor) -> torch.Tensor:
    """T_end per path (P,): t0_m + e^{μ_m + 3σ_m} of each path's last sub-movement."""
    return (t0 + torch.exp(mu + 3.0 * sigma))[last]
