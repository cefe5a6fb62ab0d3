"""What a plugin object of each kind looks like (structural typing, no base class needed).

The host checks every object a plugin returns against its kind's protocol when the plugin
registers (:func:`check_plugin_object`), so a plugin missing ``name`` or a method fails
at start-up with a sentence naming it, not in the middle of a job.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import torch

    from inkmotion.geometry.traces import Traces
    from inkmotion.jobs.shell import Job
    from inkmotion.sigma_lognormal.plan import MotorPlan


@dataclass
class JobInputs:
    """A job's inputs as an initialiser sees them: whichever exist are set.

    ``traces``: strokes in canvas px; ``image``: (H, W) or (3, H, W) tensor in [0, 1];
    ``saliency``: (H, W) map in [0, 1]; ``caption``: text; ``canvas``: (width, height) px;
    ``targets``: how many virtual targets (sub-movements) the job asks for, None for the
    initialiser's own default (an initialiser that derives them from the input ignores it).
    """

    canvas: tuple[int, int]
    traces: Traces | None = None
    image: torch.Tensor | None = None
    saliency: torch.Tensor | None = None
    caption: str | None = None
    targets: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class Reference:
    """What an image loss (or a saliency estimator) compares with: an image, a caption, or
    both. ``extra`` carries what a job kind shares with its plugins, e.g. ``"clip"``: the
    job's loaded CLIP model (:class:`inkmotion.clip.model.LoadedClip`), loaded once."""

    image: torch.Tensor | None = None  # (H, W) ink coverage in [0, 1], or (3, H, W) RGB
    caption: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)


class Plugin(Protocol):
    name: str
    description: str


class JobKind(Plugin, Protocol):
    queue: str
    inputs: tuple  # of inkmotion.jobs.kind.InputSpec
    Params: type  # a dataclass (inkmotion.jobs.params)
    examples: tuple  # command lines shown by --help

    def steps(self, params: Any) -> int:
        """How many steps a job with ``params`` reports."""

    def run(self, job: Job) -> dict:
        """Do the work, writing artifacts into ``job.folder``; return the report."""


class Reader(Plugin, Protocol):
    def can_read(self, source: str) -> bool:
        """True when this reader understands ``source`` (a path or ``scheme:value``)."""

    def read(self, source: str) -> Traces:
        """Parse ``source``; raise :class:`inkmotion.errors.InputError` on bad input."""


class Initialiser(Plugin, Protocol):
    def __call__(self, inputs: JobInputs, *, width: float, dtype: torch.dtype,
                 device: torch.device, **options: Any) -> list[MotorPlan]:
        """One motor plan per trajectory (pen lift between plans) from the job's inputs."""


class ImageLoss(Plugin, Protocol):
    def prepare(self, reference: Reference, **options: Any) -> Any:
        """A callable ``loss(rendered (H, W)) -> scalar`` bound to ``reference``."""


class Renderer(Plugin, Protocol):
    def __call__(
        self, segments: torch.Tensor, widths: torch.Tensor, height: int, width: int
    ) -> torch.Tensor:
        """Render cubic segments to coverage (H, W) in [0, 1]: segments (S, 4, 2) with
        widths (S,), or (S, 4, 3) whose third coordinate is the radius in px (widths then
        ignored; the 2.5D plans, the width varying along the stroke).

        Optional: ``session(device, static=None)`` returning a callable with the same
        signature that plans its sizes once per fit (static shapes, no device reads on a
        GPU) and offers ``overflow`` (a 0-d bool tensor) and ``replan_if_needed()``; the
        objective uses it when present (see the built-in 'raster')."""


class Saliency(Plugin, Protocol):
    def __call__(self, image: torch.Tensor, reference: Reference, **options: Any
                 ) -> torch.Tensor:
        """An (H, W) map in [0, 1] of where ``image`` (3, H, W) RGB in [0, 1] draws the eye;
        ``reference`` may hold a caption and the job's CLIP model (``extra["clip"]``)."""


class RobotBackend(Plugin, Protocol):
    def execute(self, program: Any, folder: Path, **options: Any) -> dict:
        """Execute or export ``program`` (a :class:`inkmotion.robot.types.RobotProgram`:
        setup, timed pen-tip path, joint trajectory), writing its files into ``folder``;
        return the figures for report.json. Optional: ``replay(program, result, stream)``
        logging the execution into the job's rerun recording."""


#: plugin kind -> (protocol, the attributes and methods an object must have)
REQUIRED: dict[str, tuple[str, ...]] = {
    "job-kind": ("queue", "inputs", "Params", "steps", "run"),
    "reader": ("can_read", "read"),
    "initialiser": ("__call__",),
    "image-loss": ("prepare",),
    "renderer": ("__call__",),
    "saliency": ("__call__",),
    "robot-backend": ("execute",),
}


def check_plugin_object(kind: str, obj: Any) -> str | None:
    """Why ``obj`` is not a valid plugin of ``kind`` (one phrase), or None when it is."""
    name = getattr(obj, "name", None)
    if not isinstance(name, str) or not name or any(c.isspace() for c in name):
        return f"a {kind} plugin object {obj!r} has no valid `name` (a word)"
    if not isinstance(getattr(obj, "description", None), str):
        return f"the {kind} plugin {name!r} has no `description` string"
    missing = [a for a in REQUIRED.get(kind, ()) if not hasattr(obj, a)]
    if missing:
        return f"the {kind} plugin {name!r} lacks {', '.join(missing)}"
    not_callable = [a for a in REQUIRED.get(kind, ())
                    if a in ("__call__", "can_read", "read", "prepare", "steps", "run", "execute")
                    and not callable(getattr(obj, a, None) if a != "__call__" else obj)]
    if not_callable:
        return f"the {kind} plugin {name!r}: {', '.join(not_callable)} must be callable"
    if kind == "job-kind":
        import dataclasses

        if not (isinstance(obj.Params, type) and dataclasses.is_dataclass(obj.Params)):
            return f"the job kind {name!r}: Params must be a dataclass"
        if not isinstance(obj.queue, str) or not obj.queue:
            return f"the job kind {name!r}: queue must name a Celery queue"
    return None
