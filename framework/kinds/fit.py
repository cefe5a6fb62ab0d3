"""The 'fit' job kind's work: a ΣΛ motion fitted to a drawing (the paper's "fitting
trajectories to an image"): read the input, initialise one motor plan per stroke, optimise
them through the differentiable renderer against the image loss, the smoothing cost and
the trace term in stages with plan edits between them (:mod:`inkmotion.fitting.stages`),
write the artifacts. The plugin :mod:`inkmotion.plugins.fit` declares the kind.

Artifacts: the plan's own (:func:`inkmotion.kinds.optimisation.write_plan_artifacts`),
input.json, overlay.png, human_speeds.png when the input has time stamps (+ job.json,
report.json and recording.rrd from the shell). The report adds to the plan's keys
(:func:`~inkmotion.kinds.optimisation.plan_report`) the Chamfer distance between the input
polylines and the fitted trajectory, the share of Δt at a clamp bound, the fit's speed
peaks, the recorded ones when there are time stamps, the quality verdict and the record of
each fit stage; its ``metrics`` go to the job store.

Importing this module imports no torch (the command line lists kinds at once).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.jobs.params import PluginChoice, param, plugin_param
from inkmotion.kinds.optimisation import MAX_CANVAS, OptimisationParams

if TYPE_CHECKING:
    from inkmotion.fitting.stages import RefineSettings, StagedFit, StagedProblem
    from inkmotion.jobs.kind import ResolvedJob
    from inkmotion.jobs.shell import Job


@dataclass
class FitParams(OptimisationParams):
    """Parameters of a fit; defaults are the authors' except
    where ``inkmotion benchmark`` over the real tags said otherwise, at the authors' plan
    density (DCE relevance 2.5, 29–32 sub-movements on the paper's tags): 300 steps
    (spec 13, issue 32's job time: over the development set the same 19 of 21 inputs
    meet every goal as at spec 12's 400, T_end at or below the authors' on 14 of 21
    against 15, in three quarters of the time; the tempo ladder's share of them at
    0.12 or 0.3 instead of 0.2 left 18 meeting every goal), the ladder's mean within
    0.55 px (spec 13; at 300 steps 0.5 px left T_end at or below the authors' on 14 of
    21, 0.55 on 15, 0.6 on 16, all three with 19 meeting every goal, 0.65 on 16 with 18;
    0.55 keeps its bound, less the 3 % margin, 0.07 px under the 0.6-px goal) whose
    learning rates decay to 0.3 of their start (spec 7: over the development set 17 of 21
    inputs meet every goal, T_end at or below the authors' on 9, mean Chamfer 0.352 px
    averaged; spec 6's 600 steps decaying to 0.1: 17, 9, 0.367 px, in 1.5× the time; a
    decay to 0.1 in 400 steps left 16 of 21 and one to 0.2 T_end at or below the
    authors' on 8: the last steps at a tenth of the rates did little), λ = 45 (50 put a
    two-move stroke's overlap on its floor in 1 of 84 picture fits), w_σ = 10 (the
    authors' w_σ = 50 forces equal overlaps along a path, so corners and smooth runs get
    the same Δt: 10 lets smooth runs overlap more at the same fit), the smoothing cost
    over the whole drawing, and two rounds of plan edits. λ trades accuracy for rapidity
    (README, "Sparse motor plans"): from 50 on overlaps of two-move strokes sit on their
    floor on some inputs. Each field's ``earlier`` holds the defaults of older spec
    versions (2: the authors' objective and no plan edits; 3: no trace term, every edit
    kept, merges blind to corners; 4: plan edits on a budget, no tolerance; 5: no weight
    on the trace's worst misses; 6: 600 steps decaying to 0.1; 7: edits blind to where
    the motion strays from the ink; 8: only a worst miss brought within its goal keeps an
    edit that gains less than its targets must, and an edit that pins overlaps on a clamp
    bound may be kept; 9: a last stage that pins overlaps is kept; 10: edits judged by
    accuracy alone, not by the time they add; 11: the minimum-time cost divided by the
    edited plan's own count of sub-movements, and no tempo ladder; 12: 400 steps and the
    ladder's mean within 0.5 px; 13: arcs that turn at most a quarter circle, the
    authors' clamp of δ, on which 83 of the development set's 301 sub-movements sat).
    ``max_turn`` is 180° since spec 14: a small hook or the loop of a script letter is
    one movement's half circle; over the development set 38 of 296 δ then sit on their
    clamp, the mean Chamfer averaged 0.441 → 0.428 px, the held-out words' 0.459 → 0.435
    px (T_end ratio 0.435 → 0.427), and T_end is at or below the authors' on 16 of 21
    against 15. Since spec 15 each lognormal's shape Ac learns (``lr_ac`` 0.003; 14:
    fixed at 0.01, the authors' default) and a floor barrier (``w_floor``) keeps every
    overlap's windows and speed peaks off the 0.1 floor: over the development set T_end
    is then at or below the authors' on 18 of 21 at 300 steps (16 at spec 14) and on all
    21 at 600 (18), all 21 meet every goal at 300 steps (18), mean Chamfer 0.418 px
    averaged (0.428). With a first barrier on the windows' gap alone, lr_ac 0.002 and
    0.004 gave 19 as rapid with 20 meeting every goal; without a barrier
    temptTag-2010_7_28_15_3_5's two hooks slid their overlaps onto the floor. Since spec
    16 a rung of the tempo ladder that leaves the goals is followed by one at a λ halfway
    back (``rapid_backs_off``; 15: it ended the ladder and the fit): 49873's first rung
    (λ × 1.5) took its worst miss from 5.0 to 7.3 px, past the ladder's allowance, and
    ended it at T_end 0.572 (the authors' 0.52); backed off to × 1.25, 1.375 and 1.44 it
    ends at 0.449, and over the development set T_end is at or below the authors' on 19
    of 21 at 300 steps (18), with every goal met on all 21. Since spec 17 the
    initialiser starts each δ at the trace's bend up to a half circle (the 'dce'
    initialiser's ``max_bend``; 16: a quarter circle, so a script loop's sub-movements
    began at half their turn) and δ learns at 0.2 rad a step (``lr_delta``; 16: 0.1, set
    when δ's range was a quarter circle each way, half of today's): text:giraffe, whose
    tall f loops the fit cut across, 0.963 → 0.406 px mean; over the development set at
    300 steps T_end at or below the authors' on 20 of 21 (19), mean Chamfer 0.412 px
    averaged (0.417), worst max 5.99 px (6.39), every goal met on all 21; at 600 steps
    21 of 21 (21), every goal on 21 (20). Either change alone helped less: the bend alone
    took the word to 0.728 px, the rate alone to 0.422 px but left a corpus tag slower
    than the authors' at 600 steps (0.574 against 0.53). Since spec 18 each rung of the
    tempo ladder runs its learning rates down from the middle of the fit's decay to its
    end over its own steps (``rapid_settle``; 17: every step of a rung at the middle's
    rates, so a rung was judged on a plan still moving: temptTag-2010_7_28_15_43_31's
    rungs rose from 0.51 px of mean to 0.54–0.55 px at any λ, even × 1.06): with the
    same code (the step's hand-written gradients), over the development set at 300 steps
    T_end at or below the authors' on 20 of 21 (19), mean Chamfer 0.403 px averaged
    (0.416), every goal met on all 21 (21); at 600 steps 21 of 21 (20), mean 0.383 px
    (0.400), every goal on 21 (21). Since spec 19 an edit whose refit halves a goal's
    miss is kept as one that meets the goal is (``rescue_halfway``; 18: the refit had to
    meet it by the 3 % margin): text:giraffe's first edit took its mean from 0.643 to
    0.602 px and was rolled back, leaving the word at 0.643 px; kept, the fit goes on to
    0.424 px. Every plan of the development set is the same bytes at 300 and 600 steps;
    36 of 36 words meet every goal (35)."""

    w_trace: float = param(5.0, "Weight of the trace term: the fitted motion's distance "
                           "from the input polylines, both ways (0: the image alone).",
                           minimum=0, earlier={3: 0.0})
    w_worst: float = param(1.0, "Weight of the trace term's worst misses: a soft maximum "
                           "(2 px) of how far the input lies from the motion beyond a pen's "
                           "width (3 px at 350), so a cusp or a hook the fit cuts short pulls "
                           "as hard as the rest of the trace (0: mean distances alone).",
                           minimum=0, earlier={5: 0.0})
    smooth_over: str = param("pooled", "The minimum-time cost: 'pooled' (ΣT_end/Σm and one "
                             "Var(Δt) over all the drawing's overlaps), 'drawing' (ΣT_end/Σm, "
                             "Var(Δt) per path, averaged) or 'path' (the authors': mean over "
                             "paths of T_end/m + w_σ·Var(Δt)).",
                             choices=("pooled", "drawing", "path"),
                             earlier={3: "drawing", 2: "path"})
    w_floor: float = param(0.0064, "Weight of the overlaps' floor barrier in the "
                           "minimum-time cost: an overlap Δt within 0.05 of its 0.1 floor is "
                           "pushed off it; against the time cost alone it settles 0.015 above "
                           "the floor at the default w and T = 0.8. 0: none.",
                           minimum=0, earlier={14: 0.0})
    targets: str = param("default", "Sub-movements: 'default' (the initialiser's sparse "
                         "plan, refined), N (about N in all) or 'auto' (the fewest that "
                         "reach --max-error).")
    refine: int = param(2, "Edits of the plan between fit stages in 'default' mode (targets "
                        "where the fit misses most, merges where Δt is pinned); 0: none.",
                        minimum=0, maximum=10, earlier={2: 0})
    merge: bool = param(True, "Merge two sub-movements whose overlap Δt sits on its floor "
                        "between fit stages.")
    rollback: bool = param(True, "Undo a plan edit whose refit fits the input worse (by "
                           "Chamfer mean/0.6 + max/8 px at 350 px) and go on from before it.",
                           earlier={3: False})
    keep_corners: bool = param(True, "Merges never remove the target of a sharp corner or "
                               "hook of the input (a turn of 60° or more).", earlier={3: False})
    max_error: float = param(2.0, "--targets auto: the goal for the max Chamfer distance, px.",
                             minimum=0.05)
    tolerance: float = param(0.0, "px on a 350-px canvas (scaled with it) within which the "
                             "motion may leave the input at no cost, to be more rapid: the "
                             "trace term counts only distance beyond it, and the image loss "
                             "compares with the ink widened by it on both sides (0: as close "
                             "as it can).", minimum=0, maximum=20, earlier={4: 0.0})
    strays: bool = param(True, "Plan edits also add a target where the motion strays more "
                         "than 8 px (at 350 px) from any ink, a shortcut across bare paper "
                         "that other passes hide, at the ink nearest it.",
                         earlier={7: False})
    rescue_mean: bool = param(True, "An edit whose refit brings the mean distance from above "
                              "its 0.6-px goal (at 350 px) to within it is kept whatever its "
                              "new targets gain each, as one that brings the worst miss "
                              "within 8 px is, when rolling it back would end the edits.",
                              earlier={8: False})
    rescue_halfway: bool = param(True, "An edit whose refit halves a goal's miss (the mean "
                                 "or the worst distance beyond its goal) rescues the fit as "
                                 "one that meets the goal does: the steps after it close the "
                                 "rest (without it the edit must reach the goal itself).",
                                 earlier={18: False})
    unpinned: bool = param(True, "Roll back an edit whose refit leaves more overlaps Δt on "
                           "a clamp bound than before it (sub-movements that start as nearly "
                           "at once as the model allows: more targets than movements), "
                           "unless it brings a worst miss within 8 px.", earlier={8: False})
    unpinned_end: bool = param(True, "Undo the last stage when it only went on from the "
                               "last kept plan (no edit) and left more overlaps Δt on a "
                               "clamp bound: the plan it went on from is the result.",
                               earlier={9: False})
    weigh_time: bool = param(True, "Judge a plan edit by the time it adds too: the "
                             "criterion it must lower is mean/0.6 + max/8 px (at 350 px) + "
                             "the T_end ratio/0.65, so a target that slows the motion buys "
                             "that time back in accuracy; an edit that frees overlaps Δt "
                             "from a clamp bound and draws more accurately is kept.",
                             earlier={10: False})
    time_by_initial_moves: bool = param(True, "The minimum-time cost divides each path's "
                                        "T_end by its initial plan's sub-movements, so "
                                        "targets a plan edit adds do not make the "
                                        "motion's time cheaper (without it, by the "
                                        "plan's own count).", earlier={11: False})
    rapid_within: float = param(0.55, "After the plan edits, the last --rapid-share of the steps "
                                "seeks a more rapid motion: λ raised in rungs (×1.5, 2, 3, "
                                "4) while the mean distance stays within this many px (at "
                                "350 px, scaled with the canvas), the worst within 8 px "
                                "and at most 2 px beyond where it was, and no overlap "
                                "lands on a clamp bound; the most rapid "
                                "such rung is the result (0: no rungs, every step for the "
                                "stages).", minimum=0, maximum=20,
                                earlier={11: 0.0, 12: 0.5})
    rapid_share: float = param(0.2, "The tempo ladder's share of the steps (with "
                               "--rapid-within above 0), split among its four rungs; the "
                               "plan's stages and edits take the rest. More gives the "
                               "ladder more steps to make the motion rapid and the edits "
                               "fewer to fit it.", minimum=0.05, maximum=0.8)
    rapid_backs_off: bool = param(True, "A rung of the tempo ladder that leaves the goals "
                                  "is followed by one at the λ halfway between the last "
                                  "factor within them and its own, going on from the last "
                                  "rung within them, so every announced step runs (without "
                                  "it the first such rung ends the ladder and the fit).",
                                  earlier={15: False})
    rapid_settle: bool = param(True, "Each rung of the tempo ladder runs its learning "
                               "rates down from the middle of the fit's decay to its end, so "
                               "a rung is judged on a plan that has settled (without it "
                               "every step of a rung runs at the middle's rates).",
                               earlier={17: False})
    sparsity: str = param("hand", "How plan edits keep the plan sparse: 'hand' (a target only "
                          "for a miss wider than the pen, 3 px at 350, that it fixes; m "
                          "within 1.25× the initial count, +2 below 8) or 'budget' (spec 4's: "
                          "misses above 2 px, the whole 25 % + 2 may be spent).",
                          choices=("hand", "budget"), earlier={4: "budget"})
    reader: PluginChoice | None = plugin_param(
        "reader", None, "Reader plugin (default: the first that accepts the input).")
    tracer: PluginChoice = plugin_param("tracer", "skeleton", "Tracer plugin: how a picture "
                                        "input (PNG, JPEG, ...) becomes strokes.")
    invert: bool = param(False, "A picture input is light ink on dark paper (without it, "
                         "dark ink on light paper, the other way round detected).")
    varying_width: bool = param(False, "A picture input's ink width along each stroke "
                                "becomes the plan's radius (a brush drawing fitted as one); "
                                "without it the pen is the ink's median width.")
    initialiser: PluginChoice = plugin_param("initialiser", "dce", "Initialiser plugin.")
    losses: list[PluginChoice] = plugin_param("image-loss", "mse",
                                              "Image-loss plugin (repeatable).", many=True,
                                              flag="--loss")

    def validate(self) -> None:
        if not self.losses:
            raise SpecError("The fit job needs at least one image loss (e.g. --loss mse).")
        target_count(self.targets)  # refuses anything but default, auto or a count

    def refine_settings(self) -> RefineSettings:
        """How the fit edits its plan between stages (:mod:`inkmotion.fitting.stages`)."""
        from inkmotion.fitting.stages import RefineSettings

        count = target_count(self.targets)
        mode = self.targets if count is None else "fixed"
        return RefineSettings(mode=mode, rounds=self.refine, merge=self.merge,
                              max_error=self.max_error, rollback=self.rollback,
                              protect_corners=self.keep_corners, sparsity=self.sparsity,
                              strays=self.strays, rescue_mean=self.rescue_mean,
                              rescue_halfway=self.rescue_halfway,
                              unpinned=self.unpinned, unpinned_end=self.unpinned_end,
                              weigh_time=self.weigh_time, rapid_within=self.rapid_within,
                              tempo_share=self.rapid_share,
                              backs_off=self.rapid_backs_off,
                              rungs_settle=self.rapid_settle)


#: the modules a fit imports while it runs (with torch, scipy and OpenCV under them), for
#: :func:`warm_up`; a test fits a recorded tag after it and finds nothing left to import
RUN_MODULES = (
    "torch",
    "inkmotion.fitting.stages",
    "inkmotion.fitting.trace_loss",
    "inkmotion.fitting.quality",
    "inkmotion.fitting.batch_objective",
    "inkmotion.evaluation.fit_motion",
    "inkmotion.evaluation.human",
    "inkmotion.kinds.evaluate",
    "inkmotion.kinds.read",
    "inkmotion.outputs.images",
    "inkmotion.outputs.speed_plot",
    "inkmotion.outputs.svg",
    "inkmotion.outputs.trajectory_csv",
    "inkmotion.rendering.drawing",
    "inkmotion.rendering.raster",
    "inkmotion.image_losses.multiscale_mse",
    "inkmotion.sigma_lognormal.speed",
    "inkmotion.tracing.picture",
)


def warm_up() -> None:
    """Import :data:`RUN_MODULES`, so that a process's first fit runs as its later ones do
    (a worker calls this before it takes jobs). A fresh process's first default fit of
    sample:tempt-1 took 3.1–4.4 s of job time here and its second 2.8–2.9 s: the
    difference is these imports (about 1.7 s in all with torch, 0.45 s of them inside the
    job), and a first fit after them took 2.7–3.0 s. Imports only, no tensor made, so a
    prefork worker may call it before it forks its pool."""
    import importlib

    for name in RUN_MODULES:
        importlib.import_module(name)


def target_count(targets: str) -> int | None:
    """The N of ``--targets N``; None for 'default' and 'auto'; a SpecError otherwise."""
    if targets in ("default", "auto"):
        return None
    try:
        n = int(targets)
    except ValueError:
        n = 0
    if n < 1:
        raise SpecError(f"--targets {targets!r} must be 'default', 'auto' or a number of "
                        "sub-movements of at least 1, e.g. --targets 30.")
    return n


def run(job: Job) -> dict[str, Any]:
    """Fit one drawing (the module docstring); the report."""
    from inkmotion.kinds.optimisation import optimise_plans

    problem, finish = _prepare(job)
    return finish(optimise_plans(problem))


def run_together(jobs: list[Job]) -> list[dict[str, Any] | BaseException]:
    """Several fit jobs as one batched optimisation
    (:func:`~inkmotion.fitting.stages.fit_together_in_stages`), each with its own
    input, plan edits, observers, checkpoints and artifacts: a report per job, or the
    error of a job whose input could not be read (the others go on without it)."""
    from inkmotion.errors import InkmotionError
    from inkmotion.fitting.stages import fit_together_in_stages
    from inkmotion.jobs.shell import seed_everything

    outcomes: list[Any] = []
    for job in jobs:
        seed_everything(job.spec.seed)  # as run_job seeds a job before its run
        try:
            outcomes.append(_prepare(job))
        except InkmotionError as exc:
            outcomes.append(exc)
    ready = [o for o in outcomes if not isinstance(o, BaseException)]
    staged = iter(fit_together_in_stages([problem for problem, _ in ready]) if ready
                  else [])
    return [o if isinstance(o, BaseException) else o[1](next(staged)) for o in outcomes]


def _prepare(job: Job) -> tuple[StagedProblem, Any]:
    """Read, initialise and set up the optimisation of a fit job: its
    :class:`~inkmotion.fitting.stages.StagedProblem`, and the function that writes the
    artifacts of its staged fit and returns the report."""
    import numpy as np
    import torch

    from inkmotion.fitting.objective import Objective
    from inkmotion.fitting.quality import REFERENCE_SIZE
    from inkmotion.kinds.optimisation import image_losses, initial_plans, staged_problem
    from inkmotion.plugin_host.protocols import JobInputs, Reference
    from inkmotion.rendering.drawing import render_polylines

    p: FitParams = job.params
    dtype = torch.float32
    source = job.spec.inputs["drawing"]
    traces, width = read_drawing(job.resolved)
    canvas = (int(traces.width), int(traces.height))
    renderer = job.renderer(p.renderer)
    plans = initial_plans(job, p.initialiser,
                          JobInputs(canvas, traces=traces, targets=target_count(p.targets)),
                          width=width, dtype=dtype, device=job.device)
    asked = _targets_note(p, plans)
    tolerance = p.tolerance * max(canvas) / REFERENCE_SIZE  # canvas px
    if traces.picture is not None:  # the picture itself is what the fit is judged against
        target = torch.as_tensor(traces.picture, dtype=dtype, device=job.device)
        within = target if tolerance == 0 else torch.as_tensor(
            widened(traces.picture, tolerance), dtype=dtype, device=job.device)
    else:
        target = render_polylines(renderer, traces.strokes, width, canvas, dtype, job.device)
        within = target if tolerance == 0 else render_polylines(
            renderer, traces.strokes, width + 2 * tolerance, canvas, dtype, job.device)
    objective = Objective(renderer, image_losses(job, Reference(image=within)), canvas,
                          p.weights(smooth_over=p.smooth_over, w_trace=p.w_trace,
                                    w_floor=p.w_floor),
                          trace=_trace_term(traces, plans, dtype, job.device, tolerance,
                                            p.w_worst)
                          if p.w_trace > 0 else None,
                          time_moves=[plan.m for plan in plans]
                          if p.time_by_initial_moves else None)
    job.start(canvas, target, traces.strokes)
    strokes = [np.asarray(st, dtype=np.float64)[:, :2] for st in traces.strokes]

    def finish(staged: StagedFit) -> dict[str, Any]:
        report = _write(job, traces, staged, canvas, target)
        said = [f"{source}: {note}." for note in  # a reader's (filled SVG shapes) and a
                [*traces.meta.get("notes", []),  # picture's (reduced, inverted, upright)
                 *traces.meta.get("extraction", {}).get("notes", [])]]
        unused = [] if traces.picture is not None else [
            f"{flag} applies to a picture input only; {source} is not one, so it has no "
            "effect." for flag, on in (("--invert", p.invert),
                                       ("--varying-width", p.varying_width)) if on]
        small = _small_detail(traces, target, width, p.size, source)
        notes = (said + unused + _ignored_options(p) + ([asked] if asked else [])
                 + ([small] if small else []))
        if notes:
            report["warnings"] = [*notes, *report.get("warnings", [])]
        return report

    return staged_problem(job, plans, objective, _optimiser_settings(job, traces), strokes,
                          p.refine_settings()), finish


def read_drawing(job: ResolvedJob) -> tuple[Any, float]:
    """The drawing of a fit job on its canvas, and its pen's width there: the input read as
    the job reads it (a picture through its tracer, with ``--invert`` and
    ``--varying-width``; anything else through the readers), scaled to ``--size``, a
    picture's pen checked. Raises :class:`~inkmotion.errors.InputError` on an input the fit
    refuses: ``inkmotion submit`` calls it before queueing (:meth:`check_inputs`)."""
    from inkmotion.jobs.params import options_dict
    from inkmotion.kinds.read import read_input, trace_input
    from inkmotion.samples import locate
    from inkmotion.tracing.picture import is_picture

    p: FitParams = job.params
    source = job.spec.inputs["drawing"]
    if p.reader is None and is_picture(locate(source)):
        traces, _ = trace_input(source, job.plugin(p.tracer), invert=p.invert,
                                varying_width=p.varying_width,
                                **options_dict(job.options_of(p.tracer)))
    elif p.reader is None:
        traces = read_input(source)
    else:
        traces = read_input(source, reader=p.reader.name,
                            options=options_dict(job.options_of(p.reader)))
    traces = traces.fit_to_canvas(p.size)
    width = _pen_width(traces, p)
    _check_pen(traces, width, source)
    return traces, width


def check_inputs(job: ResolvedJob) -> None:
    """Refuse, with the sentence the run would give, a drawing the fit cannot read."""
    read_drawing(job)


#: learning rate of a 2.5D plan's radius, px (the generation kinds' default)
LR_RADIUS = 0.1


def shapes_learn(job: Job) -> bool:
    """Whether the fit's shapes Ac learn: ``lr_ac`` > 0 and a renderer whose image does not
    depend on the timing. A renderer that paints by speed (``paints_by_speed``, the
    'spray' one) makes the shapes a knob of the paint's density: through it, a 40-step
    fit of text:hi at 120 px with shapes that learn ended with a larger loss than it began
    with (image loss 0.0601 → 0.0600, T_end 0.99×), with fixed shapes 0.0601 → 0.0361."""
    p = job.params
    return p.lr_ac > 0 and not getattr(job.plugin(p.renderer), "paints_by_speed", False)


def _optimiser_settings(job: Job, traces: Any) -> Any:
    """Adam's settings (the shapes' rate 0 where :func:`shapes_learn` says no); for traces
    with a radius (``--varying-width``) the radius is learnt too, within half the thinnest
    to 1.5 × the widest of the input's radii."""
    from dataclasses import replace

    p = job.params
    if not any(s.shape[1] == 3 for s in traces.strokes):
        settings = p.optimiser_settings()
    else:
        import numpy as np

        radii = np.concatenate([s[:, 2] for s in traces.strokes if s.shape[1] == 3])
        settings = p.optimiser_settings(lr_radius=LR_RADIUS, radius_range=(
            max(0.25, 0.5 * float(radii.min())), max(1.0, 1.5 * float(radii.max()))))
    return settings if shapes_learn(job) else replace(settings, lr_ac=0.0)


def _pen_width(traces: Any, p: FitParams) -> float:
    """The pen's width on the canvas: ``--width``, or for a picture its ink's median width
    (scaled to the canvas), what the picture says the pen was."""
    scale = traces.meta.get("canvas_from_picture", {}).get("scale")
    if scale is None:
        return p.width
    return max(1.0, traces.meta["extraction"]["ink_width_px"]["median"] * scale)


#: a picture's pen, enlarged with its drawing to fill the canvas, is at most this share
#: of the canvas's longer side: past it the ink is a dot or a blot, not lines
MAX_PEN_SHARE = 0.2


def _check_pen(traces: Any, width: float, source: str) -> None:
    """Refuse a picture whose drawing is a mark about as wide as it is long (a dot, a
    tick, a blot): filled to the canvas its pen would be wider than
    :data:`MAX_PEN_SHARE` of it, a fit of nothing but a smear, slow as its pen is wide."""
    import numpy as np

    from inkmotion.errors import InputError

    scale = traces.meta.get("canvas_from_picture", {}).get("scale")
    if scale is None or width <= MAX_PEN_SHARE * max(traces.width, traces.height):
        return
    ink = traces.meta["extraction"]["ink_width_px"]["median"]
    points = np.concatenate([s[:, :2] for s in traces.strokes])
    span = float(np.ptp(points, axis=0).max()) / scale  # the drawing's extent, picture px
    raise InputError(f"{source}: the drawing is a mark about as wide as it is long (its ink "
                     f"{ink:.0f} px wide, its lines at most {span:.0f} px long): enlarged to "
                     f"fill the canvas its pen would be {width:.0f} px, over a fifth of the "
                     "canvas, so there are no lines to draw; give a picture whose lines are "
                     "longer than they are wide.")


#: a drawing whose shorter side on the canvas spans fewer pen widths than this, and whose
#: strokes overlap (below :data:`MERGED_INK`), is drawn too small for its pen (a long line
#: of text at 350 px); the size suggested then gives it twice as many
DETAIL_PENS = 5.0
#: ink area over (stroke length × pen width) below which strokes overlap: 1 for strokes
#: apart, about 0.55 for a line of 176 characters at 350 px (0.77 for 43, readable)
MERGED_INK = 0.7


def _small_detail(traces: Any, target: Any, width: float, size: int, source: str
                  ) -> str | None:
    """A warning when the drawing's shorter side on the canvas spans fewer than
    :data:`DETAIL_PENS` pen widths and its ink ``target`` (H, W) covers less than
    :data:`MERGED_INK` of its strokes' length × the pen (the strokes merge, so a fit that
    follows the input closely is still unreadable), with the ``--size`` that gives it
    twice the pens; None otherwise (a straight line, a dashed one, is thin and apart)."""
    import math

    import numpy as np

    points = np.concatenate([s[:, :2] for s in traces.strokes])
    extent = float(np.ptp(points, axis=0).min())
    if extent >= DETAIL_PENS * width:
        return None
    length = sum(float(np.linalg.norm(np.diff(s[:, :2], axis=0), axis=1).sum())
                 for s in traces.strokes)
    if float(target.sum()) >= MERGED_INK * length * width:
        return None
    larger = math.ceil(size * 2 * DETAIL_PENS * width / max(extent, 1e-9) / 50) * 50
    what = (f"give --size {larger}, or split the drawing" if larger <= MAX_CANVAS else
            "split the drawing, or look for a stray point far from the rest")
    return (f"{source}: the drawing is {extent:.3g} px across its shorter side on "
            f"this {size}-px canvas, under {DETAIL_PENS:g} widths of the {width:.1f}-px pen, "
            f"so its strokes merge and it is hard to read even where the fit follows it (a "
            f"long line of text); {what}.")


def widened(ink: Any, by: float) -> Any:
    """The ink (H, W) grown by ``by`` px on every side (a grey dilation by a disc)."""
    import cv2
    import numpy as np

    r = max(1, int(round(by)))
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return cv2.dilate(np.asarray(ink, dtype=np.float32), disc)


def _ignored_options(p: FitParams) -> list[str]:
    """Warnings for options set away from their defaults that the chosen ``--targets`` mode
    does not use (every option a user sets takes effect or says why not)."""
    from dataclasses import fields

    defaults = {f.name: f.default for f in fields(FitParams)}
    only = {"max_error": ("auto",), "refine": ("default",), "merge": ("default",),
            "rollback": ("default",), "keep_corners": ("default",),
            "sparsity": ("default",)}
    mode = p.targets if p.targets in ("default", "auto") else "N"
    out = []
    for name, modes in only.items():
        value = getattr(p, name)
        if mode not in modes and value != defaults[name]:
            flag = "--" + ("no-" if value is False else "") + name.replace("_", "-")
            out.append(f"{flag} applies to --targets {' or '.join(modes)} only; with "
                       f"--targets {p.targets} it has no effect.")
    return out


def _targets_note(p: FitParams, plans: list) -> str | None:
    """A warning when ``--targets N`` could not be met within 25 %: how many sub-movements
    the initialiser placed instead and why."""
    n = target_count(p.targets)
    made = sum(plan.m for plan in plans)
    if n is None or abs(made - n) <= 0.25 * n:
        return None
    why = (" (it places targets on input vertices only, and this input has no more)"
           if made < n and p.initialiser.name == "dce" else "")
    return (f"--targets {n}: the {p.initialiser.name} initialiser made {made} sub-movements "
            f"on this input{why}; the fit uses those.")


#: recorded speed peaks per sub-movement of the plan from which the plan is said to be
#: much sparser than the hand's motion (the development set's tags: at most 0.8)
HAND_PEAKS_PER_MOVE = 2.0


def _sparser_than_the_hand(p: FitParams, recorded: dict[str, Any] | None,
                           plans: list) -> str | None:
    """A warning when the recording has at least :data:`HAND_PEAKS_PER_MOVE` speed peaks
    per sub-movement of the plan: its strokes are small beside the whole drawing, whose
    size sets the plan's density, so the plan is far sparser than the hand moved."""
    moves = sum(plan.m for plan in plans)
    if recorded is None or recorded["recorded_peaks"] < HAND_PEAKS_PER_MOVE * moves:
        return None
    denser = ("a lower --dce-relevance or --targets N" if p.initialiser.name == "dce"
              else "--targets N")
    return (f"the recording's speed has {recorded['recorded_peaks']} peaks, the plan "
            f"{moves} sub-movements over {len(plans)} strokes: it is far sparser than the "
            "hand moved, because a plan's density follows the whole drawing's size and "
            f"these strokes are small beside it; {denser} makes it denser (with a --size "
            f"above {p.size} if its overlaps then sit on their floor).")


def _auto_short(p: FitParams, chamfer_max: float, plans: list, rounds: int) -> str | None:
    """A warning when ``--targets auto`` ended above its ``--max-error``: how far, with how
    many sub-movements, after how many rounds."""
    if p.targets != "auto" or chamfer_max <= p.max_error:
        return None
    return (f"--targets auto did not reach --max-error {p.max_error:g} px: its best plan "
            f"misses by up to {chamfer_max:.2f} px with {sum(plan.m for plan in plans)} "
            f"sub-movements (after {rounds} rounds of fitting); try --steps "
            f"{2 * p.steps} or a larger --max-error.")


def _trace_term(traces: Any, plans: list, dtype: Any, device: Any,
                tolerance: float = 0.0, worst: float = 0.0) -> Any:
    """The trace term of the fit (:mod:`inkmotion.fitting.trace_loss`), each stroke owned by
    the paths whose initial trajectory follows it, free within ``tolerance`` canvas px,
    its worst misses weighed by ``worst``."""
    from inkmotion.fitting.quality import REFERENCE_SIZE
    from inkmotion.fitting.trace_loss import TraceLoss, TraceReference
    from inkmotion.outputs.sampling import on_cpu, sample

    unit = max(traces.width, traces.height) / REFERENCE_SIZE
    reference = TraceReference.of(traces.validated().strokes, dtype=dtype, device=device,
                                  unit=unit)
    owners = reference.ownership([sample(on_cpu(p)).positions for p in plans])
    return TraceLoss(reference, owners, tolerance=tolerance, worst=worst)


def _write(job: Job, traces: Any, staged: StagedFit, canvas: tuple[int, int],
           target: Any) -> dict:
    """The fit's artifacts (from CPU copies of the plans) and its report."""
    import json

    from inkmotion.evaluation.fit_motion import (
        ac_at_clamp,
        delta_at_clamp,
        delta_t_at_clamp,
        fit_speed_peaks,
        pinned_overlaps,
    )
    from inkmotion.fitting.quality import chamfer_of
    from inkmotion.kinds.optimisation import plan_report, write_plan_artifacts
    from inkmotion.outputs import write_overlay
    from inkmotion.outputs.sampling import on_cpu
    from inkmotion.sigma_lognormal import Drawing

    folder = job.folder
    fit = staged.result
    plans = [on_cpu(p) for p in fit.plans]
    size = (float(canvas[0]), float(canvas[1]))
    rendered = fit.rendered.cpu()
    report = plan_report(job, staged, plans, canvas)
    report.update(write_plan_artifacts(job, plans, rendered, canvas))
    chamfer_mean, chamfer_max = chamfer_of(traces.strokes, plans)
    drawing = Drawing(size, plans)
    metrics = report["metrics"]
    metrics.update(chamfer_mean_px=chamfer_mean, chamfer_max_px=chamfer_max,
                   t_end_ratio_multi=t_end_ratio_multi(staged),
                   delta_t_at_clamp=delta_t_at_clamp(plans),
                   delta_at_clamp=delta_at_clamp(plans, job.params.delta_limit),
                   ac_at_clamp=ac_at_clamp(plans),
                   fit_speed_peaks=fit_speed_peaks(drawing))
    report.update(t_end_ratio_multi=metrics["t_end_ratio_multi"],
                  chamfer_mean_px=chamfer_mean, chamfer_max_px=chamfer_max,
                  delta_t_at_clamp=metrics["delta_t_at_clamp"],
                  delta_at_clamp=metrics["delta_at_clamp"],
                  ac_at_clamp=metrics["ac_at_clamp"],
                  shapes_learned=shapes_learn(job),
                  speed_peaks=metrics["fit_speed_peaks"], stages=staged.stages)
    report.update(quality_verdict(traces, plans, size, chamfer_max, job.params))
    metrics["quality"] = report["quality"]
    pinned = pinned_overlaps(plans)
    report["pinned_overlaps"] = [{"path": k, "move": i, "bound": b} for k, i, b in pinned]
    if pinned:
        report["warnings"] = [*report.get("warnings", []), pinned_warning(pinned, plans,
                                                                    job.params)]
    recorded, left_out = _recorded_peaks(job, drawing)
    said = [w for w in (_auto_short(job.params, chamfer_max, plans, len(staged.stages)),
                        left_out, _sparser_than_the_hand(job.params, recorded, plans)) if w]
    if said:
        report["warnings"] = [*report.get("warnings", []), *said]
    if recorded is not None:
        report["recorded"] = recorded
        metrics["recorded_peaks"] = recorded["recorded_peaks"]
        metrics["matched_peaks"] = recorded["matched_peaks"]
    if "extraction" in traces.meta:  # a picture: how it was traced, and where it lies
        report["extraction"] = {**traces.meta["extraction"],
                                "canvas_from_picture": traces.meta["canvas_from_picture"],
                                "pen_width_px": plans[0].width if plans else None}
    (folder / "input.json").write_text(json.dumps(
        {"canvas": {"width": canvas[0], "height": canvas[1]},
         "traces": [s.tolist() for s in traces.strokes]}))
    write_overlay(folder / "overlay.png", target.cpu(), rendered, traces=traces.strokes,
                  positions=[p.points.numpy() for p in plans])
    return report


def quality_verdict(traces: Any, plans: list, size: tuple[float, float], chamfer_max: float,
                    p: FitParams) -> dict[str, Any]:
    """``quality`` ("good" or "poor": the max Chamfer distance ``chamfer_max`` above 8 px at
    350 px, scaled with the canvas, :mod:`inkmotion.fitting.quality`) and, when poor,
    ``quality_figures`` and one warning naming where the fit misses most and what to try
    (only then is the worst miss looked for)."""
    from inkmotion.fitting.quality import poor_above, worst_miss
    from inkmotion.initialisers.dce import BEND_ESTIMATE

    longer = max(size)
    limit = poor_above(longer)
    if chamfer_max <= limit:
        return {"quality": "good"}
    miss = worst_miss([s[:, :2] for s in traces.strokes], plans)
    tries = []
    if p.targets != "auto":
        tries.append("--targets auto")
    tries.append(f"--steps {2 * p.steps}")
    if p.renderer.name != "raster":
        tries.append("--renderer raster")
    dce = p.initialiser.options if p.initialiser.name == "dce" else None
    if dce is not None and dce.get("bend", True) \
            and dce.get("bend_estimate", BEND_ESTIMATE) == "peak":
        tries.append("--dce-bend-estimate between")  # a turn started as an arch (dce.py)
    x, y = miss.point
    warning = (f"the fit misses stroke {miss.stroke + 1} of {len(traces.strokes)} by "
               f"{miss.distance:.1f} px near ({x:.0f}, {y:.0f}) px (more than "
               f"{limit:.1f} px on this {longer:.0f}-px canvas); try {' or '.join(tries)}.")
    return {"quality": "poor", "warnings": [warning],
            "quality_figures": {"worst_stroke": miss.stroke, "worst_point_px": [x, y],
                                "worst_distance_px": miss.distance, "poor_above_px": limit}}


def pinned_warning(pinned: list[tuple[int, int, float]], plans: list, p: FitParams) -> str:
    """One sentence on the overlaps Δt a fit left on a clamp bound (``pinned``, from
    :func:`inkmotion.evaluation.fit_motion.pinned_overlaps`): where, what it means and what
    to try."""
    from inkmotion.evaluation.fit_motion import overlap_count
    from inkmotion.sigma_lognormal.params import DELTA_T_RANGE

    paths: dict[int, list[str]] = {}
    for k, i, _ in pinned:
        paths.setdefault(k, []).append(str(i))
    places = "; ".join(f"path {k}: sub-movement{'s' * (len(i) > 1)} {', '.join(i)}"
                       for k, i in list(paths.items())[:3]) + ("; …" if len(paths) > 3 else "")
    floor = sum(b == DELTA_T_RANGE[0] for _, _, b in pinned)
    if floor:
        fewer = sum(plan.m for plan in plans) - floor
        tries = ["--refine 0 (no targets added)"] if p.targets == "default" and p.refine else []
        meaning = (f"they start as nearly at once as the model allows ({DELTA_T_RANGE[0]}), "
                   "so the plan has more targets than the motion has movements there; try "
                   + " or ".join([*tries, f"--targets {fewer}"]))
    else:
        meaning = (f"they start as far apart as the model allows ({DELTA_T_RANGE[1]}); try a "
                   "larger --lambda")
    return (f"Δt of {len(pinned)} of {overlap_count(plans)} overlaps sits on its bound "
            f"({places}): "
            f"{meaning}.")


def t_end_ratio_multi(staged: Any) -> float:
    """T_end after / before the fit over the paths that began with 2 or more sub-movements
    (:func:`inkmotion.fitting.quality.t_end_ratio`); NaN when there is none."""
    from inkmotion.fitting.quality import t_end_ratio

    return t_end_ratio(staged.initial_path_moves, staged.initial_t_end,
                       staged.result.final_t_end)


def _recorded_peaks(job: Job, drawing: Any) -> tuple[dict[str, Any] | None, str | None]:
    """The recorded motion's duration and speed peaks and how the fit's match them, when the
    input carries time stamps (the evaluation's human agreement; its plot is
    human_speeds.png); None otherwise. Also what that comparison left out, or None."""
    from inkmotion.kinds.evaluate import recorded_agreement

    p: FitParams = job.params
    return recorded_agreement(job.spec.inputs["drawing"], drawing,
                              job.folder / "human_speeds.png",
                              p.reader.name if p.reader else None,
                              job.options(p.reader) if p.reader else None)
