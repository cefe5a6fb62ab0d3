"""The optimisation core of every kind that optimises a motor plan (fit, tag, abstract).

One home for what they share:

- :class:`OptimisationParams`: the parameters of the compound objective λ·L_smooth +
  w_I·Σ L_I + w_c·L_canvas and of Adam (the paper's "Implementation details"), each
  default written once, with the defaults older spec versions had (``earlier``, see
  :func:`inkmotion.jobs.params.param`); :meth:`~OptimisationParams.weights` and
  :meth:`~OptimisationParams.optimiser_settings` hand them to the engine, which keeps no
  defaults of its own;
- :func:`optimise_plans`: the optimisation itself, through the staged fit of
  :mod:`inkmotion.fitting.stages` (a kind without plan edits runs it as one stage), so
  every such kind checkpoints and resumes the same way, bit for bit on the CPU;
- :func:`write_plan_artifacts` and :func:`plan_report`: the artifacts every such kind
  writes (plan.json, drawing.svg, drawing.png, speed.png, trajectory.csv, spray.png on
  request) and the report keys they share.

Importing this module imports no torch: the command line builds its options from the
parameter classes at start-up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inkmotion.errors import PluginError
from inkmotion.jobs.params import PluginChoice, param, plugin_param

if TYPE_CHECKING:
    import numpy as np
    import torch

    from inkmotion.fitting.objective import Objective, Weights
    from inkmotion.fitting.optimise import OptimiserSettings
    from inkmotion.fitting.stages import RefineSettings, StagedFit, StagedProblem
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import Reference
    from inkmotion.sigma_lognormal.plan import MotorPlan


#: the largest canvas (``--size``) an optimisation takes, px
MAX_CANVAS = 4096


@dataclass
class OptimisationParams:
    """The objective's weights and Adam's settings, shared by the kinds that optimise a
    plan. The defaults are the fit's (:class:`inkmotion.kinds.fit.FitParams` says why); a
    kind with other defaults declares them with :func:`inkmotion.jobs.params.redefault`.
    ``earlier`` holds the fit's defaults of spec version 2 (the authors': 300 steps,
    λ = 20, w_σ = 50), of versions 3–6 (600 steps decaying to 0.1), of versions 7–12
    (400 steps) and of versions up to 16 (δ's learning rate 0.1, set for the quarter
    circle its range was before version 14)."""

    steps: int = param(300, "Adam steps.", minimum=1, maximum=100_000,
                       earlier={2: 300, 6: 600, 12: 400})
    size: int = param(350, "Canvas longer side, px.", minimum=32, maximum=MAX_CANVAS)
    width: float = param(3.0, "Stroke width, px.", minimum=0.01, maximum=256)
    lambda_smooth: float = param(45.0, "Weight λ of the smoothing (minimum-time) cost.",
                                 minimum=0, flag="--lambda", earlier={2: 20.0})
    w_image: float = param(200.0, "Weight of the image loss.", minimum=0)
    w_sigma: float = param(10.0, "Weight of Var(Δt) in the smoothing cost.", minimum=0,
                           earlier={2: 50.0})
    w_canvas: float = param(1.0, "Weight of the term keeping targets on the canvas.",
                            minimum=0)
    lr_points: float = param(2.0, "Learning rate of the virtual targets, px.", minimum=0)
    lr_delta_t: float = param(0.05, "Learning rate of the overlaps Δt.", minimum=0)
    lr_delta: float = param(0.2, "Learning rate of the turning angles δ, radians.",
                            minimum=0, earlier={16: 0.1})
    lr_ac: float = param(0.003, "Learning rate of the shapes Ac (0 keeps them fixed): "
                         "each lognormal's skew, so a sub-movement may do most of its "
                         "movement early in its window and the next overlap it sooner.",
                         minimum=0, earlier={14: 0.0})
    lr_final: float = param(0.3, "Cosine decay of the learning rates to this fraction.",
                            minimum=0, maximum=1, earlier={6: 0.1})
    max_turn: float = param(180.0, "The most one sub-movement's arc may turn, degrees: the "
                            "clamp of |δ| (180: a half circle, a hook or a small loop in "
                            "one movement; 90: the authors' quarter circle).",
                            minimum=1, maximum=180, earlier={13: 90.0})
    samples_per_move: int = param(5, "Bézier segments per lognormal on the fitting grid.",
                                  minimum=1, maximum=100)
    renderer: PluginChoice = plugin_param("renderer", "raster", "Renderer plugin.")
    spray_preview: bool = param(False, "Also write spray.png, the spray-paint preview of "
                                "the result (seeded by the job's seed).")

    @property
    def delta_limit(self) -> float:
        """``max_turn`` in radians: the clamp of |δ| (the optimiser's ``delta_limit``)."""
        return math.radians(self.max_turn)

    def weights(self, *, smooth_over: str = "path", w_trace: float = 0.0,
                w_floor: float = 0.0) -> Weights:
        """The objective's weights (:class:`inkmotion.fitting.objective.Weights`);
        ``smooth_over``, ``w_trace`` and ``w_floor`` for the kinds that declare them (the
        others use the authors' per-path smoothing cost, no trace term and no floor
        barrier)."""
        from inkmotion.fitting.objective import Weights

        return Weights(self.lambda_smooth, self.w_image, self.w_sigma, self.w_canvas,
                       self.samples_per_move, smooth_over, w_trace, w_floor)

    def optimiser_settings(self, *, lr_radius: float = 0.0,
                           radius_range: tuple[float, float] | None = None
                           ) -> OptimiserSettings:
        """Adam's settings (:class:`inkmotion.fitting.optimise.OptimiserSettings`); the
        radius ones for the kinds whose plans may carry a stroke radius (2.5D)."""
        from inkmotion.fitting.optimise import OptimiserSettings

        return OptimiserSettings(self.steps, self.lr_points, self.lr_delta_t, self.lr_delta,
                                 self.lr_ac, self.lr_final, lr_radius=lr_radius,
                                 radius_range=radius_range,
                                 delta_limit=self.delta_limit)


def image_losses(job: Job, reference: Reference) -> dict[str, Any]:
    """The job's image-loss plugins bound to ``reference``, by name (``params.losses``),
    another package's held to its contract (:class:`CheckedLoss`)."""
    from inkmotion.plugin_host.manager import is_built_in

    out = {}
    for c in job.params.losses:
        plugin = job.plugin(c)
        bound = plugin.prepare(reference, **job.options(c))
        if not callable(bound):
            raise PluginError(f"The image-loss plugin {c.name!r}: prepare() returned "
                              f"{type(bound).__name__}, not the loss function; return a "
                              f"callable loss(rendered) -> 0-d tensor.")
        out[c.name] = bound if is_built_in(plugin) else CheckedLoss(c.name, bound)
    return out


def initial_plans(job: Job, choice: PluginChoice, inputs: Any, **options: Any
                  ) -> list[MotorPlan]:
    """The first motor plans from the initialiser plugin ``choice`` (called with
    ``inputs`` and ``options`` besides its own options); another package's result is held
    to the Initialiser protocol: a non-empty list of motor plans with finite targets."""
    from inkmotion.plugin_host.manager import is_built_in
    from inkmotion.sigma_lognormal.plan import MotorPlan

    initialiser = job.plugin(choice)
    plans = initialiser(inputs, **options, **job.options(choice))
    if is_built_in(initialiser):
        return plans
    said = f"The initialiser plugin {choice.name!r} returned"
    if not isinstance(plans, list) or not all(isinstance(p, MotorPlan) for p in plans):
        raise PluginError(f"{said} {type(plans).__name__}; it must return a list of "
                          f"MotorPlan, one per stroke.")
    if not plans:
        raise PluginError(f"{said} no plan; it must return at least one MotorPlan.")
    if not all(bool(p.points.isfinite().all()) for p in plans):
        raise PluginError(f"{said} targets that are not finite (NaN or inf); check its "
                          f"arithmetic.")
    return plans


class CheckedLoss:
    """An image-loss plugin's bound loss whose every value is checked for what the fit
    needs (the BoundLoss protocol): a 0-d tensor, carrying a gradient whenever the
    rendering does. Shapes and flags only: no device read."""

    def __init__(self, name: str, loss: Any) -> None:
        self.name, self.loss = name, loss

    def __getattr__(self, name: str) -> Any:  # the loss's own members (e.g. ``stack``)
        if name in ("name", "loss"):  # not set yet (a copy being made): no recursion
            raise AttributeError(name)
        return getattr(self.loss, name)

    def __call__(self, rendered: torch.Tensor) -> torch.Tensor:
        import torch

        value = self.loss(rendered)
        if not isinstance(value, torch.Tensor) or value.dim() != 0:
            got = (f"a tensor of shape {tuple(value.shape)}" if isinstance(value, torch.Tensor)
                   else type(value).__name__)
            raise PluginError(f"The image-loss plugin {self.name!r} returned {got}; its loss "
                              f"must return a 0-d tensor (e.g. .mean() or .sum() of the "
                              f"per-pixel values).")
        if rendered.requires_grad and not value.requires_grad:
            raise PluginError(f"The image-loss plugin {self.name!r} returned a value with no "
                              f"gradient (detached, or computed outside torch), so the fit "
                              f"cannot learn from it; compute it from the rendering with torch "
                              f"operations.")
        return value


def staged_problem(job: Job, plans: list[MotorPlan], objective: Objective,
                   settings: OptimiserSettings, strokes: list[np.ndarray] | None = None,
                   refine: RefineSettings | None = None) -> StagedProblem:
    """One job's optimisation as the staged fit takes it, with the job's observers and
    checkpoints; ``refine`` None: one stage, the plan never edited (the generation kinds),
    ``strokes`` the input polylines the edits and the quality figures measure against."""
    from inkmotion.fitting.stages import RefineSettings, StagedProblem

    return StagedProblem(plans, objective, settings, list(strokes or []),
                         refine or RefineSettings(mode="fixed"), job.observers,
                         job.checkpoints)


def optimise_plans(problem: StagedProblem) -> StagedFit:
    """Optimise one job's plans (:func:`inkmotion.fitting.stages.fit_in_stages`): the
    job's checkpoints are written as it goes, and a job that finds one of its own resumes
    from it (``StagedFit.resumed_from_step``)."""
    from inkmotion.fitting.stages import fit_together_in_stages

    return fit_together_in_stages([problem])[0]


def write_plan_artifacts(job: Job, plans: list[MotorPlan], rendered: Any,
                         canvas: tuple[int, int]) -> dict[str, Any]:
    """plan.json, drawing.svg, drawing.png (``rendered``, the final coverage (H, W)),
    speed.png, trajectory.csv and, with ``--spray-preview``, spray.png of ``plans`` (CPU
    copies) in the job's folder; returns the report keys they add (``spray_drips``)."""
    from inkmotion.geometry.bezier import bezier_segments
    from inkmotion.outputs import write_png, write_speed_plot, write_svg, write_trajectory_csv
    from inkmotion.sigma_lognormal import Drawing

    folder: Path = job.folder
    size = (float(canvas[0]), float(canvas[1]))
    drawing = Drawing(size, plans)
    drawing.save(folder / "plan.json")
    write_svg(folder / "drawing.svg", [bezier_segments(p).detach() for p in plans],
              [p.width for p in plans], size)
    write_png(folder / "drawing.png", rendered)
    write_speed_plot(folder / "speed.png", plans)
    write_trajectory_csv(folder / "trajectory.csv", plans)
    if not job.params.spray_preview:
        return {}
    from inkmotion.rendering.render_plan import write_spray_png

    return {"spray_drips": write_spray_png(folder / "spray.png", drawing, job.spec.seed)}


def plan_report(job: Job, staged: StagedFit, plans: list[MotorPlan],
                canvas: tuple[int, int]) -> dict[str, Any]:
    """The report keys of every plan-optimising kind: steps, wall time of the
    optimisation, the plan's size (paths, sub-movements), the loss terms and T_end before
    and after, and — when the job is checkpointed — where it resumed from and the
    checkpoints written; ``metrics`` (for the job store) starts with T_end's ratio and
    the plan's size."""
    fit = staged.result
    t0, t1 = sum(staged.initial_t_end), sum(fit.final_t_end)
    moves = sum(p.m for p in plans)
    metrics: dict[str, Any] = {"t_end_ratio": t1 / t0 if t0 > 0 else float("nan"),
                               "moves": moves}
    report: dict[str, Any] = {
        "steps": staged.steps,
        "fit_s": round(staged.wall_s, 3),
        "s_per_step": round(staged.wall_s / max(staged.steps, 1), 4),
        "paths": len(plans),
        "moves": moves,
        "canvas": {"width": canvas[0], "height": canvas[1]},
        "initial_loss": staged.initial_terms,
        "final_loss": fit.final_terms,
        "initial_t_end": t0,
        "final_t_end": t1,
        "t_end_ratio": metrics["t_end_ratio"],
        "metrics": metrics,
    }
    if job.checkpoints is not None:  # the job record's metrics carry it too
        report["resumed_from_step"] = metrics["resumed_from_step"] = staged.resumed_from_step
        report["checkpoints"] = {"written": job.checkpoints.saved,
                                 "write_s": round(job.checkpoints.save_s, 4)}
    return report
