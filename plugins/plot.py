"""Job kind "plot": a plan on a pen plotter (GRBL, Marlin, Klipper or a custom profile).
The plan is placed on the paper (``--paper``, ``--margin``, ``--orientation``, ``--scale``),
timed by one uniform time scale so the feed stays ≤ ``--v-max`` mm/s, the acceleration ≤
``--a-max`` mm/s² and every corner within the machine's junction rule, and written as short
G1 segments (``--step`` s each) whose feeds follow the ΣΛ speed. Artifacts: plot.gcode (one
file per pen for multi-pen plans), plot.svg, plot_preview.png, feed.png, report.json (time
estimate, distances drawn and travelled, peak feed). The work is in
:mod:`inkmotion.kinds.plot`, the engine in :mod:`inkmotion.plotter`; importing this module
imports neither NumPy nor torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from inkmotion.errors import SpecError
from inkmotion.jobs.kind import InputSpec
from inkmotion.jobs.params import param
from inkmotion.plugin_host import hookimpl

if TYPE_CHECKING:
    from inkmotion.jobs.kind import ResolvedJob
    from inkmotion.jobs.shell import Job
    from inkmotion.plugin_host.protocols import JobKind


@dataclass
class PlotParams:
    """Parameters of a plot (the machine's own limits live in its profile)."""

    machine: str = param("grbl", "Machine profile: grbl (servo pen, M3/M5), marlin or klipper "
                         "(pen on Z), or custom (--machine-file).",
                         choices=("grbl", "marlin", "klipper", "custom"))
    machine_file: str = param("", "TOML file with a [machine] table, for --machine custom.",
                              file=True)
    paper: str = param("A4", "Paper: A5, A4, A3, letter or WIDTHxHEIGHT in mm.")
    orientation: str = param("auto", "Paper orientation: portrait, landscape or auto (the "
                             "canvas's).", choices=("auto", "portrait", "landscape"))
    margin: float = param(15.0, "Margin on every side, mm.", minimum=0, maximum=500)
    scale: float = param(0.0, "mm per canvas px (0: the largest that fits inside the "
                         "margins).", minimum=0, maximum=100)
    v_max: float = param(0.0, "Feed limit, mm/s (0: the machine's max_feed).", minimum=0,
                         maximum=2000)
    a_max: float = param(0.0, "Acceleration limit, mm/s² (0: the machine's max_accel).",
                         minimum=0, maximum=100_000)
    step: float = param(0.01, "Time step of the G1 segments, s (100 blocks/s by default).",
                        minimum=0.002, maximum=0.5)
    junctions: str = param("strict", "Corner rule the timing leaves room for: strict (GRBL's "
                           "junction deviation and the stricter circle-through-the-corner "
                           "rule other planners use) or grbl (GRBL's only: faster on GRBL).",
                           choices=("strict", "grbl"))
    order: str = param("keep", "Stroke order: keep (the drawing's own: it is the motion) or "
                       "optimise (reorder whole strokes to cut pen-up travel).",
                       choices=("keep", "optimise"))

    def validate(self) -> None:
        if self.machine == "custom" and not self.machine_file.strip():
            raise SpecError("--machine custom needs --machine-file FILE.toml with a [machine] "
                            "table.")


class PlotKind:
    """The 'plot' job kind (see the module docstring)."""

    name = "plot"
    description = "A pen plotter draws a plan: G-code whose feeds follow the ΣΛ speed."
    queue = "simulate"  # CPU work, served by the workers that simulate robots
    inputs = (InputSpec("plan", "A plan.json written by a fit, tag or abstract job.",
                        form="file"),)
    Params = PlotParams
    examples = (
        "inkmotion run plot results/hello/plan.json --out results/hello-plot",
        "inkmotion run plot plan.json --paper A3 --v-max 60 --a-max 800 --out r/a3",
        "inkmotion run plot plan.json --machine marlin --order optimise --out r/marlin",
        "inkmotion run plot plan.json --machine custom --machine-file axi.toml --out r/axi",
        "vpype inkmotion plan.json linesort write out.svg   # the plan inside vpype",
    )

    def steps(self, params: PlotParams) -> int:
        return 3

    def check_inputs(self, job: ResolvedJob) -> None:
        """Refuse a plan.json or a machine file the run could not use (``inkmotion submit``
        asks first)."""
        from inkmotion.kinds.read import check_plan_input
        from inkmotion.plotter.machine import load_machine

        check_plan_input(job)
        load_machine(job.params.machine, job.params.machine_file or None)

    def run(self, job: Job) -> dict[str, Any]:
        from inkmotion.kinds.plot import run_plot

        return run_plot(job)


@hookimpl
def inkmotion_job_kinds() -> list[JobKind]:
    return [PlotKind()]
