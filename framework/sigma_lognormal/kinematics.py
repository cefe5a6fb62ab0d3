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
from typing import Any, NamedTuple

import torch

from inkmotion.scalar_tensors import scalar_tensors
from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch, Timing
from inkmotion.sigma_lognormal.params import end_times, onsets, sigma_mu, sigma_mu_slopes
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


def _turn(c: torch.Tensor, s: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """R[θ] d from c = cos θ, s = sin θ (M, K) and d (M, 2) -> (M, K, 2)."""
    dx, dy = d[:, None, 0], d[:, None, 1]
    return torch.stack((c * dx - s * dy, s * dx + c * dy), dim=-1)


class _Terms(NamedTuple):
    """The forward quantities of :func:`submovement_terms` (each (M, K), or (M, 1) for
    those of δ alone), kept for the acceleration and for the gradient."""

    phi: torch.Tensor  # φ(τ)
    log_phi: torch.Tensor
    z: torch.Tensor  # (ln φ − μ)/σ
    lam: torch.Tensor  # Λ
    w: torch.Tensor  # w(τ)
    h: torch.Tensor  # (M, 1) 1/sinc(δ/2π)
    sinc_h: torch.Tensor  # (M, 1) sinc(δ/2π)
    sinc_w: torch.Tensor  # sinc(δw/2π)
    cos_v: torch.Tensor  # cos, sin of θ = δ(w − ½), the velocity's angle
    sin_v: torch.Tensor
    cos_x: torch.Tensor  # cos, sin of δ(w − 1)/2, the chord's angle
    sin_x: torch.Tensor
    rot_theta: torch.Tensor  # (M, K, 2) R[θ] d
    rot_x: torch.Tensor  # (M, K, 2) R[δ(w − 1)/2] d
    chord: torch.Tensor  # (M, K, 1) h·w·sinc(δw/2π)
    x: torch.Tensor  # (M, K, D)
    v: torch.Tensor  # (M, K, D)


def _terms(tau: torch.Tensor, d: torch.Tensor, delta: torch.Tensor, sigma: torch.Tensor,
           mu: torch.Tensor) -> _Terms:
    """x_i and v_i of every sub-movement at τ (module docstring), with what they are made
    of."""
    # the numbers as 0-d tensors (inkmotion.scalar_tensors): the same bits, fewer casts
    eps, minus_half, sqrt2pi, sqrt2, one, half, two_pi = scalar_tensors(
        tau, EPS, -0.5, _SQRT2PI, _SQRT2, 1.0, 0.5, 2.0 * math.pi)
    phi = torch.relu(tau - eps) + eps
    log_phi = torch.log(phi)
    sig, mu_, dl = sigma[:, None], mu[:, None], delta[:, None]
    z = (log_phi - mu_) / sig  # (M, K)
    lam = torch.exp(minus_half * z * z) / (sig * sqrt2pi * phi)
    w = half * (one + torch.erf(z / sqrt2))
    sinc_h = torch.sinc(dl / two_pi)
    h = torch.reciprocal(sinc_h)  # (M, 1)

    planar = d[:, :2]
    theta, theta_x = dl * (w - half), dl * (w - one) * half
    cos_v, sin_v, cos_x, sin_x = (torch.cos(theta), torch.sin(theta), torch.cos(theta_x),
                                  torch.sin(theta_x))
    rot_theta = _turn(cos_v, sin_v, planar)  # R[θ] d
    sinc_w = torch.sinc(dl * w / two_pi)
    chord = (h * w * sinc_w)[..., None]
    rot_x = _turn(cos_x, sin_x, planar)
    x = chord * rot_x
    v = (lam * h)[..., None] * rot_theta
    if d.shape[1] == 3:
        dz = d[:, None, 2]
        x = torch.cat((x, (w * dz)[..., None]), dim=-1)
        v = torch.cat((v, (lam * dz)[..., None]), dim=-1)
    return _Terms(phi, log_phi, z, lam, w, h, sinc_h, sinc_w, cos_v, sin_v, cos_x, sin_x,
                  rot_theta, rot_x, chord, x, v)


def _sinc_slope(y: torch.Tensor, sinc_y: torch.Tensor, cos_pi_y: torch.Tensor) -> torch.Tensor:
    """d sinc(y)/dy = (cos πy − sinc y)/y, by its series π(−u/3 + u³/30) (u = πy) where
    |u| < 0.1 (the difference cancels there; the series' next term is u⁴/280 of it)."""
    pi, third, thirtieth, small = scalar_tensors(y, math.pi, 1.0 / 3.0, 1.0 / 30.0, 0.1)
    u = pi * y
    near = u.abs() < small
    series = pi * (u * u * u * thirtieth - u * third)
    return torch.where(near, series, (cos_pi_y - sinc_y) / torch.where(near, small, y))


class _SubmovementTerms(torch.autograd.Function):
    """x_i, v_i of :func:`submovement_terms` as one graph node (a fit's step, where no
    acceleration is asked for), the forward the same ops, the gradient written out
    (autograd's graph of it took some 240 ops a step). With G_x, G_v the incoming
    gradients, R_v = R[θ]d, R_x = R[δ(w − 1)/2]d, c the chord h·q, q = w·sinc(δw/2π),
    ⊥ the quarter turn (a, b) ↦ (−b, a):

        ∂/∂Λ = h⟨G_v, R_v⟩ (+ G_vz d_z),   ∂/∂θ = Λh⟨G_v, R_v⊥⟩,
        ∂/∂c = ⟨G_x, R_x⟩,   ∂/∂θ_x = c⟨G_x, R_x⊥⟩,   ∂/∂d = Σ_k Λh R_vᵀG_v + c R_xᵀG_x,
        ∂/∂w = δ ∂/∂θ + δ/2 ∂/∂θ_x + h cos(δw/2) ∂/∂c (+ G_xz d_z),
        ∂/∂δ = Σ_k (w − ½)∂/∂θ + (w − 1)/2 ∂/∂θ_x + h′(Λ⟨G_v, R_v⟩ + q ∂/∂c)
               + h w²/2π sinc′(δw/2π) ∂/∂c,   h′ = −h² sinc′(δ/2π)/2π,
        ∂/∂z = σφΛ ∂/∂w − zΛ ∂/∂Λ   (∂w/∂z = e^{−z²/2}/√2π = σφΛ,  ∂Λ/∂z = −zΛ),
        ∂/∂μ = −Σ_k ∂/∂z / σ,   ∂/∂σ = −Σ_k (z ∂/∂z + Λ ∂/∂Λ)/σ,
        ∂/∂τ = (∂/∂z/σ − Λ ∂/∂Λ)/φ  where τ > ε (0 below: φ's floor).
    """

    @staticmethod
    def forward(ctx: Any, tau: torch.Tensor, d: torch.Tensor, delta: torch.Tensor,
                sigma: torch.Tensor, mu: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        t = _terms(tau, d, delta, sigma, mu)
        ctx.save_for_backward(tau, d, delta, sigma, *t[:-2])
        return t.x, t.v

    @staticmethod
    def backward(ctx: Any, g_x: torch.Tensor, g_v: torch.Tensor
                 ) -> tuple[torch.Tensor | None, ...]:
        tau, d, delta, sigma, *saved = ctx.saved_tensors
        t = _Terms(*saved, None, None)  # type: ignore[arg-type]
        eps, half, one, two_pi = scalar_tensors(tau, EPS, 0.5, 1.0, 2.0 * math.pi)
        sig, dl = sigma[:, None], delta[:, None]
        gvx, gvy, gxx, gxy = g_v[..., 0], g_v[..., 1], g_x[..., 0], g_x[..., 1]
        rvx, rvy, rxx, rxy = (t.rot_theta[..., 0], t.rot_theta[..., 1], t.rot_x[..., 0],
                              t.rot_x[..., 1])
        chord = t.chord[..., 0]
        lam_h = t.lam * t.h
        along = gvx * rvx + gvy * rvy  # ⟨G_v, R_v⟩
        g_lam = t.h * along
        g_theta = lam_h * (gvy * rvx - gvx * rvy)
        g_chord = gxx * rxx + gxy * rxy
        g_theta_x = chord * (gxy * rxx - gxx * rxy)
        # Rᵀg = (c g_x + s g_y, −s g_x + c g_y), for each of the two turns
        g_dx = lam_h * (t.cos_v * gvx + t.sin_v * gvy) + chord * (t.cos_x * gxx + t.sin_x * gxy)
        g_dy = lam_h * (t.cos_v * gvy - t.sin_v * gvx) + chord * (t.cos_x * gxy - t.sin_x * gxx)
        cos_w = torch.cos(dl * t.w * half)  # ∂q/∂w, and cos(π·δw/2π) of sinc′
        g_w = dl * g_theta + dl * half * g_theta_x + t.h * cos_w * g_chord
        parts = [g_dx.sum(1), g_dy.sum(1)]
        if d.shape[1] == 3:
            dz = d[:, None, 2]
            g_w = g_w + g_x[..., 2] * dz
            g_lam = g_lam + g_v[..., 2] * dz
            parts.append((g_x[..., 2] * t.w + g_v[..., 2] * t.lam).sum(1))
        g_d = torch.stack(parts, dim=1)
        y_h, y_w = dl / two_pi, dl * t.w / two_pi
        h_slope = -(t.h * t.h) * _sinc_slope(y_h, t.sinc_h, torch.cos(dl * half)) / two_pi
        q_slope = t.w * t.w / two_pi * _sinc_slope(y_w, t.sinc_w, cos_w)
        g_delta = ((t.w - half) * g_theta + (t.w - one) * half * g_theta_x
                   + h_slope * (t.lam * along + t.w * t.sinc_w * g_chord)
                   + t.h * q_slope * g_chord).sum(1)
        g_z = sig * t.phi * t.lam * g_w - t.z * t.lam * g_lam
        g_sigma = -((t.z * g_z + t.lam * g_lam).sum(1)) / sigma
        g_mu = -g_z.sum(1) / sigma
        g_tau = torch.where(tau > eps, (g_z / sig - t.lam * g_lam) / t.phi, 0.0)
        return g_tau, g_d, g_delta, g_sigma, g_mu


def submovement_terms(
    tau: torch.Tensor,  # (M, K) t − t0
    d: torch.Tensor,  # (M, D)
    delta: torch.Tensor,  # (M,)
    sigma: torch.Tensor,  # (M,)
    mu: torch.Tensor,  # (M,)
    accelerations: bool = True,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
    """Displacement x_i, velocity and acceleration of each sub-movement at τ: (M, K, D) each
    (the acceleration None without ``accelerations``: a fit's step needs x and v only,
    and takes their gradient from :class:`_SubmovementTerms`)."""
    if not accelerations:
        if torch.is_grad_enabled() and any(
                t.requires_grad for t in (tau, d, delta, sigma, mu)):
            x, v = _SubmovementTerms.apply(tau, d, delta, sigma, mu)
        else:
            t = _terms(tau, d, delta, sigma, mu)
            x, v = t.x, t.v
        return x, v, None
    t = _terms(tau, d, delta, sigma, mu)
    sig, mu_, dl = sigma[:, None], mu[:, None], delta[:, None]
    planar = d[:, :2]
    lam_dot = t.lam * (mu_ - sig * sig - t.log_phi) / (sig * sig * t.phi)
    perp = torch.stack((-planar[:, 1], planar[:, 0]), dim=-1)
    rot_theta_perp = _turn(t.cos_v, t.sin_v, perp)  # Ṙ[θ] d = R[θ] d⊥
    a = ((lam_dot * t.h)[..., None] * t.rot_theta
         + (dl * t.lam * t.lam * t.h)[..., None] * rot_theta_perp)
    if d.shape[1] == 3:
        a = torch.cat((a, (lam_dot * d[:, None, 2])[..., None]), dim=-1)
    return t.x, t.v, a


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
    return _uniform(batch.end_times(layout, timing), layout)


def _uniform(t_end: torch.Tensor, layout: GridLayout) -> tuple[torch.Tensor, torch.Tensor]:
    """The uniform grid (times (N,), dt (P,)) of paths ending at ``t_end`` (P,)."""
    dt = t_end / (layout.counts - 1).to(t_end.dtype)
    return layout.sample_step.to(dt.dtype) * dt.index_select(0, layout.sample_path), dt


class _GridTiming(torch.autograd.Function):
    """σ, μ, t0 (M,) and the uniform grid (times (N,), dt (P,)) of a batch from its Δt, Ac
    and T, as one graph node: the forward :meth:`PlanBatch.timing` and
    :func:`uniform_times` (the same ops), the gradient written out (autograd's graph of
    them took some 180 ops a step). With the incoming gradients G and the grid's
    t_k = k·dt_p, dt_p = T_end_p/n_p, T_end_p = t0_m + e^{μ_m+3σ_m} (m the path's last
    sub-movement), t0 the running sum within a path of s_1 = −L_1, s_i = Δt_i T_i +
    L_{i−1} − L_i (L = e^{μ−3σ}), σ = √(−ln(1 − Ac)), μ = 3σ − ln((e^{6σ} − 1)/T):

        ∂/∂T_end_p = (G_dt_p + Σ_k k G_t_k)/n_p,
        ∂/∂s_j = Σ_{i ≥ j in its path} ∂/∂t0_i,   ∂/∂Δt_i = T_i ∂/∂s_i (i ≥ 2),
        ∂/∂L_i = −∂/∂s_i + ∂/∂s_{i+1} (i + 1 in the same path),
        ∂/∂μ += L ∂/∂L + e^{μ+3σ} ∂/∂T_end,   ∂/∂σ += −3L ∂/∂L + 3e^{μ+3σ} ∂/∂T_end,
        ∂/∂Ac = (∂/∂σ + μ′ ∂/∂μ)/(2σ(1 − Ac)),   μ′ = 3 − 6e^{6σ}/(e^{6σ} − 1).

    T gets no gradient (a fit never learns it)."""

    @staticmethod
    def forward(ctx: Any, delta_t: torch.Tensor, ac: torch.Tensor, T: torch.Tensor,
                layout: GridLayout) -> tuple[torch.Tensor, ...]:
        sigma, mu = sigma_mu(ac, T)
        t0 = onsets(delta_t, T, sigma, mu, layout)
        times, dt = _uniform(end_times(t0, sigma, mu, layout), layout)
        ctx.layout = layout
        ctx.save_for_backward(ac, T, sigma, mu)
        return sigma, mu, t0, times, dt

    @staticmethod
    def backward(ctx: Any, g_sigma: torch.Tensor, g_mu: torch.Tensor, g_t0: torch.Tensor,
                 g_times: torch.Tensor, g_dt: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        layout: GridLayout = ctx.layout
        ac, T, sigma, mu = ctx.saved_tensors
        three = scalar_tensors(sigma, 3.0)[0]
        n_paths, n_moves = layout.n_paths, layout.n_moves
        last = layout.last_move
        steps = layout.sample_step.to(sigma.dtype)
        g_dt = g_dt + g_dt.new_zeros(n_paths).index_add(0, layout.sample_path, steps * g_times)
        g_end = g_dt / (layout.counts - 1).to(sigma.dtype)  # (P,)
        closing = torch.exp(mu.index_select(0, last) + three * sigma.index_select(0, last))
        at_last = lambda v: g_end.new_zeros(n_moves).index_add(0, last, v)  # noqa: E731
        g_t0 = g_t0 + at_last(g_end)
        # t0_i = Σ_{j ≤ i in its path} s_j: each s_j gets the t0 gradients from j to the end
        after = torch.cat((g_t0.flip(0).cumsum(0).flip(0), g_t0.new_zeros(1)))  # (M + 1,)
        g_s = after[:n_moves] - after.index_select(
            0, layout.last_move.index_select(0, layout.move_path) + 1)
        later = (~layout.first).to(sigma.dtype)  # (M,) Δt_i and L_{i−1} take part
        lead = torch.exp(mu - three * sigma)
        g_lead = torch.cat((g_s[1:] * later[1:], g_s.new_zeros(1))) - g_s
        g_mu = g_mu + lead * g_lead + at_last(closing * g_end)
        g_sigma = g_sigma - three * lead * g_lead + at_last(three * closing * g_end)
        g_delta_t = g_s * T * later if ctx.needs_input_grad[0] else None
        g_ac = None
        if ctx.needs_input_grad[1]:
            dmu, dac = sigma_mu_slopes(ac, sigma)
            g_ac = (g_sigma + dmu * g_mu) / dac
        return g_delta_t, g_ac, None, None


def grid_timing(batch: PlanBatch, layout: GridLayout
                ) -> tuple[Timing, torch.Tensor, torch.Tensor]:
    """``batch.timing(layout)`` and ``uniform_times(batch, layout)`` of a fit's step:
    (σ, μ, t0), times (N,), dt (P,), the same values; their gradient from
    :class:`_GridTiming` where one is wanted (and T has none)."""
    if torch.is_grad_enabled() and not batch.T.requires_grad and (
            batch.delta_t.requires_grad or batch.ac.requires_grad):
        sigma, mu, t0, times, dt = _GridTiming.apply(batch.delta_t, batch.ac, batch.T,
                                                     layout)
        return (sigma, mu, t0), times, dt
    timing = batch.timing(layout)
    return (timing, *uniform_times(batch, layout, timing))


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
