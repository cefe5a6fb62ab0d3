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
d_i through one scatter and a cumulative sum. The window's sample count K is either sized
on every call (one read of the device: free on a CPU) or static, ``GridLayout.window``,
planned once with headroom, with a device-side flag saying when it no longer fits.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import torch

from inkmotion.scalar_tensors import scalar_tensors
from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch, Timing
from inkmotion.sigma_lognormal.plan import MotorPlan

EPS = 1e-5
#: half-width of the evaluated window, in σ of ln τ (Φ(−5) ≈ 3e-7 of |d| is neglected)
SUPPORT_SIGMAS = 5.0
_SQRT2 = math.sqrt(2.0)
_SQRT2PI = math.sqrt(2.0 * math.pi)


class Kinematics(NamedTuple):
    positions: torch.Tensor  # (N, D)
    velocities: torch.Tensor  # (N, D)
    accelerations: torch.Tensor | None  # (N, D); None when not asked for (a fit's step)


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
    accelerations: bool = True,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
    """Displacement x_i, velocity and acceleration of each sub-movement at τ: (M, K, D) each
    (the acceleration None without ``accelerations``: a fit's step needs x and v only)."""
    # the numbers as 0-d tensors (inkmotion.scalar_tensors): the same bits, fewer casts
    eps, minus_half, sqrt2pi, sqrt2, one, half, two_pi = scalar_tensors(
        tau, EPS, -0.5, _SQRT2PI, _SQRT2, 1.0, 0.5, 2.0 * math.pi)
    phi = torch.relu(tau - eps) + eps
    log_phi = torch.log(phi)
    sig, mu_, dl = sigma[:, None], mu[:, None], delta[:, None]
    z = (log_phi - mu_) / sig  # (M, K)
    lam = torch.exp(minus_half * z * z) / (sig * sqrt2pi * phi)
    w = half * (one + torch.erf(z / sqrt2))
    h = torch.reciprocal(torch.sinc(dl / two_pi))  # (M, 1)

    planar = d[:, :2]
    rot_theta = _rotate(dl * (w - half), planar)  # R[θ] d
    chord = (h * w * torch.sinc(dl * w / two_pi))[..., None]
    x = chord * _rotate(dl * (w - one) * half, planar)
    v = (lam * h)[..., None] * rot_theta
    a = None
    if accelerations:
        lam_dot = lam * (mu_ - sig * sig - log_phi) / (sig * sig * phi)
        perp = torch.stack((-planar[:, 1], planar[:, 0]), dim=-1)
        rot_theta_perp = _rotate(dl * (w - half), perp)  # Ṙ[θ] d = R[θ] d⊥
        a = ((lam_dot * h)[..., None] * rot_theta
             + (dl * lam * lam * h)[..., None] * rot_theta_perp)
    if d.shape[1] == 3:
        dz = d[:, None, 2]
        x = torch.cat((x, (w * dz)[..., None]), dim=-1)
        v = torch.cat((v, (lam * dz)[..., None]), dim=-1)
        if a is not None:
            a = torch.cat((a, (lam_dot * dz)[..., None]), dim=-1)
    return x, v, a


def _window_bounds(
    times: torch.Tensor,  # (N,) sorted within each path's block
    t0: torch.Tensor,  # (M,)
    sigma: torch.Tensor,  # (M,)
    mu: torch.Tensor,  # (M,)
    layout: GridLayout,
    with_centre: bool = False,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
    """Samples in each support τ ∈ [e^{μ−kσ}, e^{μ+kσ}] (k = SUPPORT_SIGMAS): first (M,),
    one past the last (M,), both within the sub-movement's own block, and (if asked) the
    sample at the median τ = e^μ (M,). One searchsorted over keys made unique per path by
    an offset computed on the device (no host read)."""
    t, t0 = times.detach().double(), t0.detach().double()
    span = t.abs().max() + t0.abs().max() + 10.0  # 0-d: wider than any block
    keys = t + layout.sample_path.double() * 4.0 * span  # (N,) increasing
    offset = layout.move_path.double() * 4.0 * span  # (M,)

    def first_at(log_tau: torch.Tensor, right: bool = False) -> torch.Tensor:
        at = t0 + torch.exp(log_tau.detach().double())  # (M,) t0 + τ
        return torch.searchsorted(keys, at + offset, right=right)

    lo = torch.maximum(first_at(mu - SUPPORT_SIGMAS * sigma), layout.move_block_start)
    hi = torch.minimum(first_at(mu + SUPPORT_SIGMAS * sigma, right=True), layout.move_block_end)
    return torch.minimum(lo, hi), hi, first_at(mu) if with_centre else None


def _fit_window(lo: torch.Tensor, hi: torch.Tensor, centre: torch.Tensor,
                window: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Windows (M,) of at most ``window`` samples: [lo, hi) itself where it fits, else the
    ``window`` samples of it around the median (the tails, the least mass, are dropped)."""
    start = torch.maximum(torch.minimum(centre - window // 2, hi - window), lo)
    return start, torch.minimum(hi, start + window)


#: a static window is planned at WINDOW_HEADROOM × the widest support seen (+ 2 samples)
WINDOW_HEADROOM = 2.0


def window_alarm(window: int) -> int:
    """Support width (samples) past which a static window of ``window`` samples raises its
    flag: ¾ of it, so a fit whose supports grow is replanned before any is truncated."""
    return window - window // 4


def plan_window(batch: PlanBatch, times: torch.Tensor, layout: GridLayout,
                headroom: float = WINDOW_HEADROOM, min_delta_t: float | None = None,
                max_ac: float = 0.1) -> GridLayout:
    """``layout`` with a static window: the largest number of samples a sub-movement's
    support covers now, × ``headroom`` + 2, at most the longest block. Reads the device
    (once, when a fit starts or its window no longer fits).

    With ``min_delta_t`` (the optimiser's clamps Δt ≥ min_delta_t, Ac ≤ max_ac) and
    ``times`` the uniform grid, the window is at least wide enough for any plan within the
    clamps, so a fit never outgrows it: the ±kσ support lasts W = T·sinh(kσ)/sinh(3σ),
    largest at σ_max = √(−ln(1 − Ac_max)), and T_end ≥ Δt_min·Σ_{i≥2} T_i bounds the grid
    step dt = T_end/n_p from below, so a support covers at most ⌈W_max/dt_min⌉ + 1 samples.
    """
    with torch.no_grad():
        sigma, mu, t0 = batch.timing(layout)
        lo, hi, _ = _window_bounds(times, t0, sigma, mu, layout)
        figures = [(hi - lo).max(), layout.counts.max()]
        if min_delta_t is not None:
            figures.append(_clamped_window(batch, layout, min_delta_t, max_ac))
        need, longest, *bound = (int(x) for x in torch.stack(figures).double().tolist())
    window = max([math.ceil(headroom * need) + 2, *bound])
    return layout.with_window(max(1, min(window, longest)))


def _clamped_window(batch: PlanBatch, layout: GridLayout, min_delta_t: float,
                    max_ac: float) -> torch.Tensor:
    """0-d: the most samples of its path's uniform grid a support can cover while
    Δt ≥ ``min_delta_t`` and Ac ≤ ``max_ac`` (see :func:`plan_window`), at most a block."""
    s_max = math.sqrt(-math.log1p(-max_ac))
    ratio = math.sinh(SUPPORT_SIGMAS * s_max) / math.sinh(3.0 * s_max)  # W / T at σ_max
    T = batch.T.detach().double()
    zeros = torch.zeros(layout.n_paths, dtype=T.dtype, device=T.device)
    rest = zeros.index_add(0, layout.move_path, T * (~layout.first))  # (P,) Σ_{i≥2} T_i
    t_max = zeros.scatter_reduce(0, layout.move_path, T, "amax")  # (P,)
    dt_min = min_delta_t * rest / (layout.counts - 1)  # (P,)
    samples = torch.ceil(ratio * t_max / dt_min) + 2  # inf when m_p = 1: capped below
    return torch.minimum(samples, layout.counts.double()).max()


def evaluate_kinematics(
    batch: PlanBatch,
    times: torch.Tensor,  # (N,) sorted within each path's block
    layout: GridLayout,
    accelerations: bool = True,
    timing: Timing | None = None,
) -> tuple[Kinematics, torch.Tensor | None]:
    """Kinematics of every path of ``batch`` at its own block of sample times, and whether
    a static window is (nearly) outgrown (0-d bool on the device; None for a dynamic one).
    Without ``accelerations`` their field is None (a fit's step: x and v are its Hermite
    segments; the acceleration terms were a third of the forward kinematics' ops).
    ``timing``: ``batch.timing(layout)`` when the caller has it (one graph of σ, μ, t0 a
    step, not two).

    Sub-movement i is evaluated on the K samples of its support only (gather → evaluate →
    scatter-add): K = ``layout.window`` when static (no host read; a support wider than
    :func:`window_alarm` sets the flag, one wider than K also loses its tails), else the
    largest support of this call (one read).
    """
    device = times.device
    n_total = times.shape[0]
    sigma, mu, t0 = timing if timing is not None else batch.timing(layout)
    d = batch.displacements(layout)  # (M, D)

    with torch.no_grad():  # window bounds: index bookkeeping, no gradient
        lo, hi, centre = _window_bounds(times, t0, sigma, mu, layout,
                                        with_centre=layout.window is not None)
        overflow = None
        if layout.window is None:  # only the sub-movements with samples in their support:
            # a long plan's block of times (kinematics' chunk) meets few of its thousands
            moving = torch.nonzero(hi > lo).squeeze(1)
            k = int((hi - lo).max()) if lo.numel() else 0
            if moving.shape[0] == lo.shape[0]:  # all of them (a fit's grid): no gathers
                moving = None
            first, ends = (lo, hi) if moving is None else (lo.index_select(0, moving),
                                                           hi.index_select(0, moving))
        else:
            k = layout.window
            overflow = (hi - lo > window_alarm(k)).any()
            lo, hi = _fit_window(lo, hi, centre, k)
            moving, first, ends = None, lo, hi
        idx = first[:, None] + torch.arange(max(k, 1), device=device)  # (M', K)
        valid = idx < ends[:, None]
        idx = torch.where(valid, idx, torch.zeros_like(idx))

    def of_moving(values: torch.Tensor) -> torch.Tensor:
        return values if moving is None else values.index_select(0, moving)

    tau = times.index_select(0, idx.reshape(-1)).view(idx.shape) - of_moving(t0)[:, None]
    x, v, a = submovement_terms(tau, of_moving(d), of_moving(batch.delta), of_moving(sigma),
                                of_moving(mu), accelerations)
    mask = valid[..., None].to(x.dtype)
    flat = idx.reshape(-1)
    dim = d.shape[1]
    zeros = torch.zeros(n_total, dim, dtype=x.dtype, device=device)
    pos = zeros.index_add(0, flat, (x * mask).reshape(-1, dim))
    vel = zeros.index_add(0, flat, (v * mask).reshape(-1, dim))
    acc = None if a is None else zeros.index_add(0, flat, (a * mask).reshape(-1, dim))

    # completed sub-movements: +d_i from the first sample after the window to the block end
    done = torch.zeros(n_total + 1, dim, dtype=x.dtype, device=device)
    done = done.index_add(0, hi, d).index_add(0, layout.move_block_end, -d)
    pos = pos + torch.cumsum(done, 0)[:n_total] + batch.start_points(layout).index_select(
        0, layout.sample_path)
    return Kinematics(pos, vel, acc), overflow


def batch_kinematics(
    batch: PlanBatch,
    times: torch.Tensor,  # (N,) sorted within each path's block
    layout: GridLayout,
) -> Kinematics:
    """Kinematics of every path of ``batch`` at its own block of sample times (N, D) each;
    see :func:`evaluate_kinematics`."""
    return evaluate_kinematics(batch, times, layout)[0]


def uniform_times(batch: PlanBatch, layout: GridLayout,
                  timing: Timing | None = None
                  ) -> tuple[torch.Tensor, torch.Tensor]:
    """The uniform grid of each path: t_k = k·T_end/n_p, k = 0..n_p (n_p = counts − 1; on
    the fitting grid n_p = 5·m_p). Returns (times (N,), dt (P,)), carrying the gradient of
    T_end; ``timing`` as for :func:`evaluate_kinematics`."""
    t_end = batch.end_times(layout, timing)  # (P,)
    dt = t_end / (layout.counts - 1).to(t_end.dtype)
    return layout.sample_step.to(dt.dtype) * dt.index_select(0, layout.sample_path), dt


#: times :func:`kinematics` evaluates at once: a long plan's samples (a plotter's or a
#: robot's, hours at 1 kHz) are taken this many at a time, so memory stays bounded
KINEMATICS_CHUNK = 250_000


def kinematics(plan: MotorPlan, t: torch.Tensor) -> Kinematics:
    """Positions, velocities and accelerations of ``plan`` at times ``t`` (n,): (n, D) each.

    Differentiable w.r.t. the plan's tensors and ``t``; any order of ``t`` is accepted;
    the times are taken :data:`KINEMATICS_CHUNK` at a time.
    """
    t = torch.as_tensor(t, dtype=plan.points.dtype, device=plan.points.device).reshape(-1)
    order = torch.argsort(t.detach())
    inverse = torch.empty_like(order)
    inverse[order] = torch.arange(order.numel(), device=order.device)
    batch = PlanBatch.from_plans([plan])
    pieces = []
    for chunk in t[order].split(KINEMATICS_CHUNK):  # memory bounded for hours of samples
        counts = torch.full((1,), chunk.numel(), dtype=torch.long, device=t.device)
        pieces.append(batch_kinematics(batch, chunk, batch.layout(counts,
                                                                  n_samples=chunk.numel())))
    out = [torch.cat(parts) for parts in zip(*pieces, strict=True)] if len(pieces) > 1 \
        else pieces[0]
    return Kinematics(*(o[inverse] for o in out))
