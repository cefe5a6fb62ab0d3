"""Host synchronisations: the counter catches each kind, and a fit step makes none.

DESIGN.md § Devices: the hot loop (kinematics → Bézier → render → loss → step) has static
shapes and no host synchronisation. The counter sees on the CPU what would make the host
wait for a CUDA device, so these tests guard the CUDA path without a GPU.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
import torch

from inkmotion.fitting.objective import Objective
from inkmotion.geometry.bezier import hermite_segments
from inkmotion.profiling import count_host_syncs, forbid_cuda_syncs
from inkmotion.profiling.problem import fit_problem, step, step_host_syncs
from inkmotion.rendering.raster import RasterSession
from inkmotion.sigma_lognormal.kinematics import (
    evaluate_kinematics,
    plan_window,
    uniform_times,
    window_alarm,
)

X = torch.tensor([1.5, 0.0, 2.0, 2.0])
MASK = torch.tensor([True, False, True, True])
REPEATS = torch.tensor([1, 2, 3])


def _index_put_with_mask() -> None:
    y = X.clone()
    y[MASK] = X[:3]  # (a scalar right-hand side is a masked_fill: no sync)


def _backward_of_mask_index() -> None:
    x = X.clone().requires_grad_(True)
    x[MASK].sum().backward()  # the forward indexes once, the backward once more


CAUGHT: dict[str, tuple[Callable[[], object], str]] = {
    "item": (lambda: X[0].item(), "Tensor.item"),
    "int": (lambda: int(X[0]), "Tensor.__int__"),
    "float": (lambda: float(X[0]), "Tensor.__float__"),
    "bool": (lambda: bool(X[0] > 0), "Tensor.__bool__"),
    "if": (lambda: 1 if (X > 0).any() else 0, "Tensor.__bool__"),
    "index": (lambda: [0, 1, 2][X[1].long()], "Tensor.__index__"),
    "tolist": (lambda: X.tolist(), "Tensor.tolist"),
    "numpy": (lambda: X.numpy(), "Tensor.numpy"),
    "cpu": (lambda: X.cpu(), "Tensor.cpu"),
    "format": (lambda: f"{X[0]:.2f}", "Tensor.__format__"),
    "equal": (lambda: torch.equal(X, X), "torch.equal"),
    "nonzero": (lambda: torch.nonzero(X), "aten.nonzero"),
    "where(cond)": (lambda: torch.where(X > 0), "aten.nonzero"),
    "argwhere": (lambda: torch.argwhere(X), "aten.nonzero"),
    "masked_select": (lambda: torch.masked_select(X, MASK), "aten.masked_select"),
    "mask index": (lambda: X[MASK], "aten.index (bool mask)"),
    "mask index_put": (_index_put_with_mask, "aten.index_put_ (bool mask)"),
    "repeat_interleave": (lambda: torch.repeat_interleave(torch.arange(3), REPEATS),
                          "aten.repeat_interleave (no output_size)"),
    "unique": (lambda: torch.unique(X), "aten.unique"),
    "scalar argument": (lambda: torch.arange(X[2].long()), "aten._local_scalar_dense (item)"),
    "upload": (lambda: torch.tensor([1.0, 2.0]), "torch.tensor (upload)"),
    "upload scalar": (lambda: torch.as_tensor(3.0), "torch.as_tensor (upload)"),
}


@pytest.mark.parametrize("case", list(CAUGHT))
def test_each_kind_is_caught_once(case: str) -> None:
    fn, name = CAUGHT[case]
    with count_host_syncs() as log:
        fn()
    assert [e.name for e in log.events] == [name], log.summary()
    assert log.events[0].where.startswith("test_host_syncs.py:")


def test_backward_is_seen() -> None:
    with count_host_syncs() as log:
        _backward_of_mask_index()
    assert log.names() == {"aten.index (bool mask)": 1, "aten.index_put (bool mask)": 1}


def test_pure_tensor_code_counts_zero() -> None:
    x = torch.linspace(0, 1, 50, requires_grad=True)
    counts = torch.tensor([10, 15, 25])
    with count_host_syncs() as log:
        seg = torch.repeat_interleave(torch.arange(3), counts, output_size=50)
        y = torch.where(x > 0.5, x.sin(), x.cos()) * seg
        idx = torch.searchsorted(x.detach(), torch.linspace(0, 1, 7))
        z = torch.zeros(3).index_add(0, seg, y) + y[idx.clamp(max=49)].sum()
        img = torch.zeros(9).scatter_reduce(0, idx.clamp(max=8), x[:7], "amax")
        (z.sum() + img.sum() + torch.cumsum(y, 0)[-1] + x.as_strided((2,), (1,)).sum()).backward()
        _ = x.shape[0] + len(x) + x.numel()  # shapes are known on the host
    assert log.count == 0, log.summary()


# --- the fit step -----------------------------------------------------------------------------
@pytest.fixture
def problem(device: torch.device) -> tuple[Objective, object]:
    """Objective and batch of a 162-lognormal fit, static shapes forced (as on CUDA)."""
    return fit_problem(device, static=True)


def test_fit_step_makes_no_host_sync(problem: tuple) -> None:
    """Forward+backward of the objective (kinematics → Bézier → raster → multi-scale MSE +
    smoothing + canvas): 0 host synchronisations after the first (planning) call."""
    objective, batch = problem
    with count_host_syncs() as first:
        step(objective, batch)
    assert first.count > 0  # the layout, the window and the render budget are planned
    for _ in range(2):
        log = step_host_syncs(objective, batch)
        assert log.count == 0, log.summary()


def test_periodic_check_reads_one_flag(device: torch.device) -> None:
    """With ``check_every=k`` the objective reads its flags once every k calls, no more."""
    objective, batch = fit_problem(device, static=True, check_every=3)
    counts = []
    for _ in range(6):
        with count_host_syncs() as log:
            step(objective, batch)
        counts.append(log.count)
    assert counts[1:] == [0, 1, 0, 0, 1]


def test_fit_step_makes_no_cuda_sync(problem: tuple, device: torch.device) -> None:
    """On a GPU, CUDA's own sync check agrees: a step after the first raises nothing."""
    if device.type != "cuda":
        pytest.skip("CUDA's sync debug mode needs a CUDA device")
    objective, batch = problem
    step(objective, batch)
    with forbid_cuda_syncs():
        step(objective, batch)
        step(objective, batch)


def test_static_and_per_call_objectives_agree(device: torch.device) -> None:
    static_obj, batch = fit_problem(device, static=True)
    dynamic_obj, _ = fit_problem(device, static=False)
    ev_s, ev_d = step(static_obj, batch), step(dynamic_obj, batch)
    torch.testing.assert_close(ev_s.total, ev_d.total, rtol=1e-5, atol=0)
    torch.testing.assert_close(ev_s.rendered, ev_d.rendered, rtol=0, atol=1e-5)


def test_kinematics_bezier_render_and_loss_each_make_none(problem: tuple) -> None:
    """Each stage alone, forward and backward, after the layout and budget are planned."""
    objective, batch = problem
    step(objective, batch)  # plans the layout and its window
    layout = objective.layout
    assert layout is not None and layout.window is not None
    with torch.no_grad():
        times, dt = uniform_times(batch, layout)
        kin, _ = evaluate_kinematics(batch, times, layout)
        segments = hermite_segments(kin.positions, kin.velocities, layout, dt)[..., :2]
        widths = batch.widths[layout.segment_path]
    positions, velocities, segments = (t.clone().requires_grad_(True)
                                       for t in (kin.positions, kin.velocities, segments))
    session = RasterSession(static=True)
    session(segments, widths, 350, 350)  # plans its budget
    loss = objective.image_losses["mse"]
    stages: dict[str, Callable[[], torch.Tensor]] = {
        "kinematics": lambda: sum(t.sum() for t in evaluate_kinematics(
            batch, uniform_times(batch, layout)[0], layout)[0]),
        "bezier": lambda: hermite_segments(positions, velocities, layout, dt).sum(),
        "render": lambda: session(segments, widths, 350, 350).sum(),
        "mse": lambda: loss(session(segments, widths, 350, 350)),
    }
    for name, stage in stages.items():
        with count_host_syncs() as log:
            stage().backward()
        assert log.count == 0, f"{name}:\n{log.summary()}"


def test_window_covers_the_clamps(problem: tuple) -> None:
    """The static window is planned for any plan within the optimiser's clamps: squeezing
    every Δt to its 0.1 clamp (T_end ≈ 10× shorter) neither truncates nor flags."""
    objective, batch = problem
    step(objective, batch)
    window = objective.layout.window
    with torch.no_grad():
        batch.delta_t.fill_(0.1)
        times, _ = uniform_times(batch, objective.layout)
        need = plan_window(batch, times, objective.layout, headroom=1.0).window - 2
    assert need <= window_alarm(window) and need > 5 * 12  # the grid is 5 samples per move
    step(objective, batch)
    assert not objective.replan_if_needed() and objective.layout.window == window


def test_outgrown_window_is_flagged_and_replanned(problem: tuple) -> None:
    """Plans past the clamps (here Δt = 0.02) outgrow the static window: the flag says so,
    the next check replans it, and the step after that is sync-free again."""
    objective, batch = problem
    step(objective, batch)
    window = objective.layout.window
    with torch.no_grad():
        batch.delta_t.fill_(0.02)
    step(objective, batch)
    assert objective.replan_if_needed()
    assert objective.layout.window is None
    step(objective, batch)  # replans
    assert objective.layout.window > window
    log = step_host_syncs(objective, batch)
    assert log.count == 0, log.summary()
    assert not objective.replan_if_needed()
    with torch.no_grad():  # the replanned window equals per-call sizing again
        times, _ = uniform_times(batch, objective.layout)
        need = plan_window(batch, times, objective.layout, headroom=1.0).window - 2
    assert objective.layout.window >= need


def test_nan_total_is_returned_not_raised(problem: tuple) -> None:
    """The objective does not check finiteness (a device read): NaN reaches the total."""
    objective, batch = problem
    step(objective, batch)
    with torch.no_grad():
        batch.delta[3] = math.nan  # only the trajectory (→ renderer) sees δ
    with count_host_syncs() as log:
        ev = objective(batch)
    assert log.count == 0, log.summary()
    assert not torch.isfinite(ev.total)


def test_bench_figure_counts_the_default_cpu_mode() -> None:
    """On the CPU the objective sizes per call (free there): a few reads, all known ones."""
    log = step_host_syncs(*fit_problem("cpu"))
    allowed = {"Tensor.__int__", "Tensor.__bool__", "Tensor.tolist",
               "aten.repeat_interleave (no output_size)", "aten.index (bool mask)",
               "aten.index_put (bool mask)", "aten.nonzero"}  # nonzero: the raster's rims
    assert set(log.names()) <= allowed, log.summary()
