"""A third-party job kind, 'spiral', registered through the ``inkmotion`` entry-point group
exactly like the built-ins: a ΣΛ motor plan whose virtual targets lie on a spiral.

It exercises what a job kind gets from the host: its own parameters (CLI options, spec
validation), its own queue ("sketch"), progress steps reported to observers, the staging
folder committed atomically, and job.json/report.json written by the shell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from inkmotion.jobs.kind import InputSpec
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl


@dataclass
class SpiralParams:
    turns: float = param(2.0, "Turns of the spiral.", minimum=0.25, maximum=20)
    targets_per_turn: int = param(6, "Virtual targets per turn.", minimum=2, maximum=64)
    radius: float = param(120.0, "Outer radius, px.", minimum=1)
    steps: int = param(8, "Steps reported (one per refinement pass).", minimum=1, maximum=1000)


class SpiralKind:
    name = "spiral"
    description = "A ΣΛ spiral named after a word (third-party example job kind)."
    queue = "sketch"
    inputs = (InputSpec("title", "Any word, written into the report.", form="text"),)
    Params = SpiralParams
    examples = ("inkmotion run spiral hello --out results/spiral --turns 3",)

    def steps(self, params: SpiralParams) -> int:
        return params.steps

    def run(self, job: Any) -> dict[str, Any]:
        import torch

        from inkmotion import MotorPlan
        from inkmotion.events import StepState
        from inkmotion.sigma_lognormal import Drawing

        p: SpiralParams = job.params
        n = max(2, round(p.turns * p.targets_per_turn))
        size = 2 * p.radius + 20
        points = []
        for k in range(n + 1):
            a = 2 * math.pi * p.turns * k / n
            r = p.radius * (k + 1) / (n + 1)
            points.append((size / 2 + r * math.cos(a), size / 2 + r * math.sin(a)))
        plan = MotorPlan.from_points(points, device=job.device)
        job.start(canvas=(int(size), int(size)))
        for step in range(1, p.steps + 1):
            t_end = plan.end_time.detach()
            job.observers.on_step(StepState(step, p.steps, {"total": torch.zeros(())}, t_end))
        Drawing((size, size), [plan.to(device="cpu")]).save(job.folder / "plan.json")
        return {"title": job.spec.inputs["title"], "moves": plan.m,
                "metrics": {"moves": plan.m, "t_end": float(plan.end_time)}}


@hookimpl
def inkmotion_job_kinds() -> list:
    return [SpiralKind()]
