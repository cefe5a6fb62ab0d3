"""ΣΛ kinematics: positions, velocities and accelerations of packed motor plans.

For sub-movement i with τ = φ(t − t0_i), φ(u) = ReLU(u − ε) + ε:

    Λ_i(t) = exp(−(ln τ − μ_i)² / 2σ_i²) / (σ_i √(2π) τ)            (paper eq. 2)
    w_i(t) = ½ [1 + erf((ln τ − μ_i) / (σ_i √2))]                     (paper eq. 3)
    θ_i(t) = −δ_i/2 + δ_i w_i(t),   h_i = 1 / sinc(δ_i / 2π)  (normalised sinc)
    v_i    = Λ_i H R[θ_i] d_i                                          (paper eq. 4)
    a_i    = Λ̇_i H R[θ_i] d_i + δ_i Λ_i² H Ṙ[θ_i] d_i   (erratum: the text prints δΛ)
    Λ̇_i   = Λ_i (μ_i − σ_i² − ln τ) / (σ_i² τ)

Position. Integrating v_i over w gives the chord of the arc swept so far, which we write
without any division by δ (so values and gradients are finite at δ = 0, no branch):

    x_i = h_i · w · sinc(δ_i w / 2π) · R[δ_i (w − 1) / 2] · d_i

(equal to the paper's closed form with M and Z; at w = 1 it is d_i; at δ = 0 it is w·d_i).
The third (radius) coordinate moves along the straight line: x = w d, v = Λ d, a = Λ̇ d.

Cost is linear in m: a lognormal is negligible outside τ ∈ [e^{μ−kσ}, e^{μ+kσ}] (k =
``SUPPORT_SIGMAS``), so each sub-movement is evaluated only on the samples in that window
(gather → evaluate → scatter-add). Samples after the window get the whole displacement
d_i through one scatter and a cumulative sum.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import torch

from inkmotion.sigma_lognormal.batch import PlanBatch
from inkmotion.sigma_lognormal.plan import MotorPlan

EPS = 1e-5
#: half-width of the evaluated window, in σ of ln τ (Φ(−5) ≈ 3e-7 of |d| is neglected)
SUPPORT_SIGMAS = 5.0
_SQRT2 = math.sqrt(2.0)
_SQRT2PI = math.sqrt(2.0 * math.pi)


class Kinematics(NamedTuple):
    positions: torch.Tensor  # (N, D)
    velocities: torch.Tensor  # (N, D)
    accelerations: torch.Tensor  # (N, D)


def _rotate(theta: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """R[θ] applied to the planar part of d: θ (M, K), d (M, 2) -> (M, K, 2)."""
    c, s = torch.cos(theta), torch.sin(theta)
    dx, dy = d[:, None, 0], d[:, None, 1]
    return torch.stack((c * dx - s * dy, s * dx + c * dy), dim=-1)


def submovement_terms(
    tau: torch.Tensor,  # (M, K) t − t0
    d: torch.Tensor,  # (M, D)
    delta: torch.Tensor,  # (M,)
    sigma: torch.Tensor,  # (M,)
    mu: torch.Tensor,  # (M,)
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Displacement x_i, velocity and acceleration of each sub-movement at τ: (M, K, D) each."""
    phi = torch.relu(tau - EPS) + EPS
    log_phi = torch.log(phi)
    sig, mu_, dl = sigma[:, None], mu[:, None], delta[:, None]
    z = (log_phi - mu_) / sig  # (M, K)
    lam = torch.exp(-0.5 * z * z) / (sig * _SQRT2PI * phi)
    w = 0.5 * (1.0 + torch.erf(z / _SQRT2))
    lam_dot = lam * (mu_ - sig * sig - log_phi) / (sig * sig * phi)
    h = 1.0 / torch.sinc(dl / (2.0 * math.pi))  # (M, 1)

    planar = d[:, :2]
    rot_theta = _rotate(dl * (w - 0.5), planar)  # R[θ] d
    perp = torch.stack((-planar[:, 1], planar[:, 0]), dim=-1)
    rot_theta_perp = _rotate(dl * (w - 0.5), perp)  # Ṙ[θ] d = R[θ] d⊥
    chord = (h * w * torch.sinc(dl * w / (2.0 * math.pi)))[..., None]
    x = chord * _rotate(dl * (w - 1.0) * 0.5, planar)
    v = (lam * h)[..., None] * rot_theta
    a = (lam_dot * h)[..., None] * rot_theta + (dl * lam * lam * h)[..., None] * rot_theta_perp
    if d.shape[1] == 3:
        dz = d[:, None, 2]
        x = torch.cat((x, (w * dz)[..., None]), dim=-1)
        v = torch.cat((v, (lam * dz)[..., None]), dim=-1)
        a = torch.cat((a, (lam_dot * dz)[..., None]), dim=-1)
    return x, v, a


def batch_kinematics(
    batch: PlanBatch,
    times: torch.Tensor,  # (N,) sorted within each path's block
    counts: torch.Tensor,  # (P,) long: samples of each path, blocks in path order
) -> Kinematics:
    """Kinematics of every path of ``batch`` at its own block of sample times."""
    device = times.device
    n_total = times.shape[0]
    sigma, mu, t0 = batch.timing()
    d = batch.displacements()  # (M, D)
    move_path = batch.move_path()  # (M,)
    block_end = torch.cumsum(counts, 0)  # (P,)
    block_start = block_end - counts
    sample_path = torch.repeat_interleave(torch.arange(batch.n_paths, device=device), counts)

    with torch.no_grad():  # window bounds: index bookkeeping, no gradient
        span = float(times.detach().abs().max()) + float(t0.detach().abs().max()) + 10.0
        keys = times.detach().double() + sample_path.double() * 4.0 * span
        offset = move_path.double() * 4.0 * span
        lo_t = (t0.detach().double() + torch.exp((mu - SUPPORT_SIGMAS * sigma).detach().double()))
        hi_t = (t0.detach().double() + torch.exp((mu + SUPPORT_SIGMAS * sigma).detach().double()))
        lo = torch.searchsorted(keys, lo_t + offset)  # (M,) first sample in the window
        hi = torch.searchsorted(keys, hi_t + offset, right=True)  # (M,) first sample after it
        lo = torch.maximum(lo, block_start[move_path])
        hi = torch.minimum(hi, block_end[move_path])
        lo = torch.minimum(lo, hi)
        k = int((hi - lo).max()) if lo.numel() else 0
        idx = lo[:, None] + torch.arange(max(k, 1), device=device)  # (M, K)
        valid = idx < hi[:, None]
        idx = torch.where(valid, idx, torch.zeros_like(idx))

    tau = times[idx] - t0[:, None]  # (M, K)
    x, v, a = submovement_terms(tau, d, batch.delta, sigma, mu)
    mask = valid[..., None].to(x.dtype)
    flat = idx.reshape(-1)
    dim = d.shape[1]
    zeros = torch.zeros(n_total, dim, dtype=x.dtype, device=device)
    pos = zeros.index_add(0, flat, (x * mask).reshape(-1, dim))
    vel = zeros.index_add(0, flat, (v * mask).reshape(-1, dim))
    acc = zeros.index_add(0, flat, (a * mask).reshape(-1, dim))

    # completed sub-movements: +d_i from the first sample after the window to the block end
    done = torch.zeros(n_total + 1, dim, dtype=x.dtype, device=device)
    done = done.index_add(0, hi, d).index_add(0, block_end[move_path], -d)
    pos = pos + torch.cumsum(done, 0)[:n_total] + batch.start_points()[sample_path]
    return Kinematics(pos, vel, acc)


def uniform_times(batch: PlanBatch, samples_per_move: int = 5) -> tuple[torch.Tensor,
                                                                          torch.Tensor,
                                                                          torch.Tensor]:
    """The fitting grid: n_p = 5·m_p segments per path, t_k = k·T_end/n_p, k = 0..n_p.

    Returns (times (N,), counts (P,), dt (P,)); times carry the gradient of T_end.
    """
    t_end = batch.end_times()  # (P,)
    n = batch.moves * samples_per_move  # (P,)
    dt = t_end / n.to(t_end.dtype)
    counts = n + 1
    path = torch.repeat_interleave(torch.arange(batch.n_paths, device=n.device), counts)
    start = torch.cumsum(counts, 0) - counts
    k = torch.arange(int(counts.sum()), device=n.device) - start[path]
    return k.to(dt.dtype) * dt[path], counts, dt


def kinematics(plan: MotorPlan, t: torch.Tensor) -> Kinematics:
    """Positions, velocities and accelerations of ``plan`` at times ``t`` (n,): (n, D) each.

    Differentiable w.r.t. the plan's tensors and ``t``; any order of ``t`` is accepted.
    """
    t = torch.as_tensor(t, dtype=plan.points.dtype, device=plan.points.device).reshape(-1)
    order = torch.argsort(t.detach())
    inverse = torch.empty_like(order)
    inverse[order] = torch.arange(order.numel(), device=order.device)
    counts = torch.tensor([t.numel()], dtype=torch.long, device=t.device)
    out = batch_kinematics(PlanBatch.from_plans([plan]), t[order], counts)
    return Kinematics(*(o[inverse] for o in out))
