"""The fit's Adam: torch.optim.Adam's arithmetic, one learning rate per tensor, each
product and sum rounded on its own (the same bits on every CPU: test_portable_math)."""

import pytest
import torch

from inkmotion.fitting.optimise import Adam


@pytest.mark.parametrize("dtype,tolerance", [(torch.float64, 1e-12), (torch.float32, 1e-5)])
def test_steps_are_torch_adams_to_round_off_under_a_changing_schedule(dtype, tolerance) -> None:
    g = torch.Generator().manual_seed(0)
    shapes, lrs = [(13, 2), (11,), (11,), (11,)], [1.0, 0.05, 0.01, 0.002]
    start = [torch.randn(s, generator=g, dtype=dtype) for s in shapes]
    ours = [t.clone().requires_grad_(True) for t in start]
    theirs = [t.clone().requires_grad_(True) for t in start]
    adam = Adam(list(zip(ours, lrs, strict=True)))
    reference = torch.optim.Adam([{"params": [p], "lr": lr} for p, lr in zip(theirs, lrs,
                                                                               strict=True)],
                                 foreach=False)
    for k in range(200):
        factor = 0.3 + 0.7 * (k % 7) / 7
        for mine, ref, shape in zip(ours, theirs, shapes, strict=True):
            grad = torch.randn(shape, generator=g, dtype=dtype) * 10.0 ** (k % 5 - 2)
            mine.grad, ref.grad = grad.clone(), grad.clone()
        for group, lr in zip(reference.param_groups, lrs, strict=True):
            group["lr"] = lr * factor
        adam.step(factor)
        reference.step()
    for a, b, s in zip(ours, theirs, start, strict=True):
        assert torch.allclose(a, b, rtol=tolerance, atol=tolerance)
        assert (a - s).abs().max() > 0.01  # it moved


def test_a_tensor_without_a_gradient_is_left_as_it_is() -> None:
    a, b = torch.ones(3, requires_grad=True), torch.ones(2, requires_grad=True)
    adam = Adam([(a, 0.1), (b, 0.1)])
    a.grad = torch.ones(3)
    adam.step()
    assert torch.equal(b, torch.ones(2)) and not torch.equal(a, torch.ones(3))
    assert float(adam.steps[1]) == 0.0 and float(adam.steps[0]) == 1.0


def test_the_shapes_are_a_leaf_of_the_fit_only_when_they_learn() -> None:
    """lr_ac = 0 (the default): Ac takes no gradient (none is used; it cost a fifth of the
    kinematics' backward) and Adam holds no moments of it; lr_ac > 0: Adam updates it."""
    from inkmotion.fitting.optimise import OptimiserSettings, _Leaves
    from inkmotion.sigma_lognormal.plan import MotorPlan

    plan = MotorPlan.from_points(torch.tensor([[0.0, 0.0], [40.0, 5.0], [60.0, 50.0]]))
    for lr_ac, learns in ((0.0, False), (0.01, True)):
        fit = _Leaves([plan], OptimiserSettings(10, lr_points=2.0, lr_delta_t=0.05,
                                                lr_delta=0.1, lr_ac=lr_ac, lr_final=0.3))
        assert fit.leaves["ac"].requires_grad is learns
        assert fit.leaves["points"].requires_grad and fit.leaves["delta_t"].requires_grad
        assert any(p is fit.leaves["ac"] for p in fit.adam.params) is learns
