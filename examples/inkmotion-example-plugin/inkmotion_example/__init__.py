"""An example inkmotion plugin package (see docs/plugins.md): the image loss ``edge`` and
the job kind ``grid``, registered through the ``inkmotion`` entry-point group.

Heavy imports (torch) happen inside the methods, so listing plugins stays fast."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from inkmotion.jobs.kind import InputSpec
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl


@dataclass
class EdgeOptions:
    """Options of the 'edge' loss (``--edge-scale`` on the command line)."""

    scale: float = param(1.0, "Multiplies the loss.", minimum=0)


class EdgeLoss:
    """Mean squared difference of the Sobel gradients of the rendered and target images."""

    name = "edge"
    description = "Gradient (Sobel) MSE: matches where stroke edges are (example plugin)."
    Options = EdgeOptions

    def prepare(self, reference: Any, scale: float = 1.0) -> Any:
        import torch
        import torch.nn.functional as F

        from inkmotion.errors import SpecError

        target = getattr(reference, "image", None)
        if target is None or target.ndim != 2:
            raise SpecError("The edge loss needs a grey target image; this job has none.")
        kx = torch.tensor([[-1.0, 0.0, 1.0], [-2.0, 0.0, 2.0], [-1.0, 0.0, 1.0]],
                          dtype=target.dtype, device=target.device)
        kernel = torch.stack((kx, kx.T))[:, None]  # (2, 1, 3, 3)

        def gradients(image: torch.Tensor) -> torch.Tensor:
            return F.conv2d(image[None, None], kernel, padding=1)

        reference_gradients = gradients(target).detach()

        def loss(rendered: torch.Tensor) -> torch.Tensor:
            return scale * ((gradients(rendered) - reference_gradients) ** 2).mean()

        return loss


@dataclass
class GridParams:
    """Parameters of the 'grid' job kind."""

    cells: int = param(3, "Targets per side of the grid.", minimum=2, maximum=32)
    spacing: float = param(40.0, "Distance between targets, px.", minimum=1)


class GridKind:
    """A motor plan that zig-zags through a grid of virtual targets (one path)."""

    name = "grid"
    description = "A ΣΛ zig-zag through an n × n grid of targets (example plugin)."
    queue = "examples"
    inputs = (InputSpec("title", "Any word, written into the report.", form="text"),)
    Params = GridParams
    examples = ("inkmotion run grid hello --cells 4 --out results/grid",)

    def steps(self, params: GridParams) -> int:
        return 1

    def run(self, job: Any) -> dict[str, Any]:
        import torch

        from inkmotion import MotorPlan
        from inkmotion.events import StepState
        from inkmotion.sigma_lognormal import Drawing

        p: GridParams = job.params
        points = []
        for row in range(p.cells):
            cols = range(p.cells) if row % 2 == 0 else reversed(range(p.cells))
            points.extend((20 + c * p.spacing, 20 + row * p.spacing) for c in cols)
        size = 40 + (p.cells - 1) * p.spacing
        plan = MotorPlan.from_points(points, device=job.device)
        job.start(canvas=(int(size), int(size)))
        job.observers.on_step(StepState(1, 1, {"total": torch.zeros(())},
                                        plan.end_time.detach()))
        Drawing((size, size), [plan.to(device="cpu")]).save(job.folder / "plan.json")
        return {"title": job.spec.inputs["title"], "moves": plan.m,
                "metrics": {"moves": plan.m, "t_end": float(plan.end_time)}}


@hookimpl
def inkmotion_image_losses() -> list:
    return [EdgeLoss()]


@hookimpl
def inkmotion_job_kinds() -> list:
    return [GridKind()]
