"""What a plugin object of each kind looks like (structural typing, no base class needed).

These classes are the plugin contract, written once: the host derives its registration
check from them (:func:`check_plugin_object`: every member of the kind's protocol in
:data:`PROTOCOLS` must exist, and its methods must be callable), and the engines take
their type hints from them (e.g. :class:`inkmotion.fitting.objective.Objective`). A plugin
missing ``name`` or a method fails at start-up with a sentence naming it, not in the
middle of a job; a member added here is checked from then on.

Optional members are declared apart, in one ``…Optional`` protocol per kind
(:data:`OPTIONAL`: a renderer's ``session``, a robot backend's ``replay``, a job kind's
``run_together``, ``warm_up`` and ``examples``, any plugin's ``Options``), so the check
never requires them while type checkers and readers still see their signatures; the code
that uses one looks it up with ``getattr(obj, name, None)``.

Importing this module imports neither torch nor the plugin manager (the heavy types are
hints only), so the engines may use it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, Protocol

if TYPE_CHECKING:
    import torch

    from inkmotion.geometry.traces import Traces
    from inkmotion.jobs.kind import ResolvedJob
    from inkmotion.jobs.shell import Job
    from inkmotion.robot.types import RobotProgram
    from inkmotion.sigma_lognormal.plan import MotorPlan
    from inkmotion.tracing.picture import Picture


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
    """What every plugin object has: a one-word ``name``, unique within its kind, and a
    one-line ``description`` shown by ``inkmotion plugins``."""

    name: str
    description: str


class PluginOptional(Protocol):
    """What any plugin object may have and the host does not require."""

    #: a dataclass of the options it takes (fields declared with
    #: ``inkmotion.jobs.params.param``), reaching the object as keyword arguments
    Options: type


# -- job kinds -------------------------------------------------------------------------

class JobKind(Plugin, Protocol):
    """A kind of job (fit, tag, simulate, …): its inputs, parameters, queue and work."""

    queue: str  # the Celery queue its jobs go to, a non-empty string
    inputs: tuple  # of inkmotion.jobs.kind.InputSpec
    Params: type  # a dataclass (inkmotion.jobs.params)

    def steps(self, params: Any) -> int:
        """How many steps a job with ``params`` reports."""

    def run(self, job: Job) -> dict:
        """Do the work, writing artifacts into ``job.folder``; return the report."""


class JobKindOptional(PluginOptional, Protocol):
    """What a job kind may have besides :class:`JobKind`."""

    examples: tuple  # command lines shown by --help

    def run_together(self, jobs: list[Job]) -> Iterable[dict | BaseException]:
        """Run several jobs of this kind (same parameters, other inputs and seeds) as one
        batched optimisation: each job's report, or the exception it failed with, in
        order (``inkmotion.jobs.shell.run_jobs_together``)."""

    def warm_up(self) -> None:
        """Import what :meth:`run` imports, so that a worker's first job of this kind runs
        as its later ones do: each worker calls it once, before it takes jobs (a prefork
        worker before it forks its pool, so imports only: no tensor, no thread, no
        device). A kind without it pays its imports in its first job."""

    def check_inputs(self, job: ResolvedJob) -> None:
        """Read the job's inputs as :meth:`run` will and raise
        :class:`~inkmotion.errors.InputError` (one sentence) on one it would refuse:
        ``inkmotion submit`` calls it, so such a job is refused before it is queued
        rather than failed later on a worker. Cheap next to the job; no artifacts."""


# -- readers and initialisers ----------------------------------------------------------

class Reader(Plugin, Protocol):
    """Turns a drawing input into traces."""

    def can_read(self, source: str) -> bool:
        """True when this reader understands ``source`` (a path or ``scheme:value``)."""

    def read(self, source: str, **options: Any) -> Traces:
        """Parse ``source``; raise :class:`inkmotion.errors.InputError` on bad input. The
        options of its ``Options`` arrive as keyword arguments when the job names the
        reader (``--reader NAME``); a reader found by ``can_read`` gets its defaults."""


class Tracer(Plugin, Protocol):
    """Turns a picture of a line drawing into traces: strokes in drawing order, each
    begun where a hand begins it, with the ink's radius as a third column when asked."""

    def __call__(self, picture: Picture, *, varying_width: bool = False,
                 **options: Any) -> Traces:
        """Traces of ``picture`` (:class:`inkmotion.tracing.picture.Picture`) in its pixels,
        ``picture.target`` (its darkness over the ink's level) attached as
        ``Traces.picture``; raise
        :class:`inkmotion.errors.InputError` when no stroke can be traced."""


class Initialiser(Plugin, Protocol):
    """Makes the first motor plans of a fit from the job's inputs."""

    def __call__(self, inputs: JobInputs, *, width: float, dtype: torch.dtype,
                 device: torch.device, **options: Any) -> list[MotorPlan]:
        """One motor plan per trajectory (pen lift between plans) from the job's inputs."""


# -- image losses ----------------------------------------------------------------------

class BoundLoss(Protocol):
    """An image loss bound to its reference (what :meth:`ImageLoss.prepare` returns)."""

    def __call__(self, rendered: torch.Tensor) -> torch.Tensor:
        """The 0-d loss of ``rendered`` (H, W) coverage in [0, 1], differentiable."""


class ImageLoss(Plugin, Protocol):
    """Compares a rendering with a reference (an image, a caption, or both)."""

    def prepare(self, reference: Reference, **options: Any) -> BoundLoss:
        """A callable ``loss(rendered (H, W)) -> scalar`` bound to ``reference``."""


# -- renderers -------------------------------------------------------------------------

class RenderFunction(Protocol):
    """The call a renderer (or its per-fit session) answers."""

    def __call__(
        self, segments: torch.Tensor, widths: torch.Tensor, height: int, width: int
    ) -> torch.Tensor:
        """Render cubic segments to coverage (H, W) in [0, 1]: segments (S, 4, 2) with
        widths (S,), or (S, 4, 3) whose third coordinate is the radius in px (widths then
        ignored; the 2.5D plans, the width varying along the stroke)."""


class Renderer(Plugin, RenderFunction, Protocol):
    """Draws Bézier segments as a differentiable coverage image (the call of
    :class:`RenderFunction`). The options of its ``Options`` arrive as keyword arguments
    of every call (and of ``session``, when it has one)."""


class RendererOptional(PluginOptional, Protocol):
    """What a renderer may have besides :class:`Renderer`; the objective uses each when
    present (see the built-in 'raster')."""

    #: True when its calls take ``canvases=`` and draw several drawings at once (count,
    #: H, W): a batched fit asks for it
    renders_canvases: bool

    def session(self, device: torch.device | str, static: bool | None = None
                ) -> RenderFunction:
        """A callable with the renderer's signature that plans its sizes once per fit
        (static shapes, no device reads on a GPU); it may offer ``overflow`` (a 0-d bool
        tensor, a budget was outgrown) and ``replan_if_needed()``."""


# -- saliency and robot backends -------------------------------------------------------

class Saliency(Plugin, Protocol):
    """Estimates where an image draws the eye."""

    def __call__(self, image: torch.Tensor, reference: Reference, **options: Any
                 ) -> torch.Tensor:
        """An (H, W) map in [0, 1] of where ``image`` (3, H, W) RGB in [0, 1] draws the eye;
        ``reference`` may hold a caption and the job's CLIP model (``extra["clip"]``)."""


class RobotBackend(Plugin, Protocol):
    """Executes or exports a robot program."""

    def execute(self, program: RobotProgram, folder: Path, **options: Any) -> dict:
        """Execute or export ``program`` (setup, timed pen-tip path, joint trajectory),
        writing its files into ``folder``; return the figures for report.json."""


class RobotBackendOptional(PluginOptional, Protocol):
    """What a robot backend may have besides :class:`RobotBackend`."""

    def replay(self, program: RobotProgram, result: dict, stream: Any) -> None:
        """Log the execution (``result``: :meth:`RobotBackend.execute`'s figures) into the
        job's rerun recording ``stream``."""


# -- the contract, by kind -------------------------------------------------------------

#: plugin kind (as users name it, the keys of ``hookspecs.KIND_HOOKS``) -> its protocol:
#: every member is required at registration
PROTOCOLS: dict[str, type] = {
    "job-kind": JobKind,
    "reader": Reader,
    "tracer": Tracer,
    "initialiser": Initialiser,
    "image-loss": ImageLoss,
    "renderer": Renderer,
    "saliency": Saliency,
    "robot-backend": RobotBackend,
}

#: plugin kind -> the protocol of the members it may have (never required)
OPTIONAL: dict[str, type] = {
    "job-kind": JobKindOptional,
    "reader": PluginOptional,
    "tracer": PluginOptional,
    "initialiser": PluginOptional,
    "image-loss": PluginOptional,
    "renderer": RendererOptional,
    "saliency": PluginOptional,
    "robot-backend": RobotBackendOptional,
}


def protocol_members(protocol: type) -> dict[str, bool]:
    """Every member ``protocol`` declares, its protocol bases' included (:class:`Plugin`'s
    ``name`` and ``description``), in declaration order (bases first, then attributes
    before methods), mapped to whether it must be callable: True for a method
    (``__call__`` included: the object itself must be callable), False for an annotated
    attribute. Private names and typing's own machinery are not members."""
    members: dict[str, bool] = {}
    for cls in reversed(protocol.__mro__):
        if cls in (object, Generic, Protocol) or not cls.__dict__.get("_is_protocol", False):
            continue
        for name in cls.__dict__.get("__annotations__", {}):
            if not name.startswith("_"):
                members.setdefault(name, False)
        for name, value in cls.__dict__.items():
            if callable(value) and (name == "__call__" or not name.startswith("_")):
                members[name] = True
    return members


def check_plugin_object(kind: str, obj: Any) -> str | None:
    """Why ``obj`` is not a valid plugin of ``kind`` (one phrase), or None when it is.

    The members checked are :func:`protocol_members` of ``PROTOCOLS[kind]``: each must
    exist, the methods must be callable; ``name`` and ``description`` first, with their
    own phrases. A job kind's ``Params`` and any plugin's ``Options`` must moreover be a
    dataclass with a default for every field, and a job kind's ``queue`` a non-empty
    string (what a protocol cannot say).
    """
    name = getattr(obj, "name", None)
    if not isinstance(name, str) or not name or any(c.isspace() for c in name):
        article = "an" if kind[0] in "aeiou" else "a"
        return (f"{article} {kind} plugin object of class {type(obj).__name__} has no valid "
                f"`name` (a word without spaces)")
    if not isinstance(getattr(obj, "description", None), str):
        return f"the {kind} plugin {name!r} has no `description` string"
    members = protocol_members(PROTOCOLS.get(kind, Plugin))
    missing = [m for m in members if not hasattr(obj, m)]
    if missing:
        return f"the {kind} plugin {name!r} lacks {', '.join(missing)}"
    not_callable = [m for m, method in members.items() if method
                    and not callable(obj if m == "__call__" else getattr(obj, m))]
    if not_callable:
        return f"the {kind} plugin {name!r}: {', '.join(not_callable)} must be callable"
    for m, method in members.items():
        problem = _call_problem(PROTOCOLS.get(kind, Plugin), m, obj) if method else None
        if problem:
            return f"the {kind} plugin {name!r}: {problem}"
    if kind == "job-kind":
        problem = _settings_problem(obj.Params, "Params")
        if problem:
            return f"the job kind {name!r}: {problem}"
        if not isinstance(obj.queue, str) or not obj.queue:
            return f"the job kind {name!r}: queue must name a Celery queue"
    elif getattr(obj, "Options", None) is not None:
        problem = _settings_problem(obj.Options, "Options")
        if problem:
            return f"the {kind} plugin {name!r}: {problem}"
    return None


def field_flag(name: str, flag: str | None = None) -> str:
    """The command-line flag of a settings field ``name`` (a job kind's parameter), e.g.
    ``--lambda-smooth``, or its declared ``flag``."""
    return flag or "--" + name.replace("_", "-")


def option_flag(plugin: str, option: str) -> str:
    """The command-line flag of a plugin's option, named after both: ``--dce-relevance``."""
    return f"--{plugin}-{option.replace('_', '-')}"


def _call_problem(protocol: type, member: str, obj: Any) -> str | None:
    """Why ``obj``'s method ``member`` cannot take the arguments inkmotion calls it with
    (the protocol's: its positional ones, each keyword-only one by name, and where the
    protocol has ``**options`` every field of the plugin's ``Options``), or None. A
    signature that cannot be read (a builtin) is taken on trust."""
    import dataclasses
    import inspect

    try:
        wanted = inspect.signature(getattr(protocol, member))
        given = inspect.signature(obj if member == "__call__" else getattr(obj, member))
    except (TypeError, ValueError):
        return None
    params = list(wanted.parameters.values())[1:]  # without self
    args = [p.name for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    kwargs = [p.name for p in params if p.kind is p.KEYWORD_ONLY]
    options = getattr(obj, "Options", None)
    passed = list(kwargs)
    if any(p.kind is p.VAR_KEYWORD for p in params) and dataclasses.is_dataclass(options):
        passed += [f.name for f in dataclasses.fields(options)]  # its options, every one
    try:
        given.bind(*args, **dict.fromkeys(passed))
    except TypeError as exc:
        call = ", ".join(args + (["*"] + kwargs if kwargs else [])
                         + (["**options"] if any(p.kind is p.VAR_KEYWORD for p in params)
                            else []))
        return (f"{member}{given} cannot take what inkmotion passes it ({exc}); declare it "
                f"as {member}(self, {call})")
    return None


def _settings_problem(cls: Any, member: str) -> str | None:
    """Why a job kind's ``Params`` or a plugin's ``Options`` cannot be its settings (one
    phrase), or None: it must be a dataclass whose fields all have a default (a job.json
    or a command line may leave any of them out) and whose type hints resolve."""
    import dataclasses
    import typing

    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        return (f"{member} must be a dataclass (add @dataclass above class "
                f"{getattr(cls, '__name__', cls)})")
    bare = [f.name for f in dataclasses.fields(cls) if f.default is dataclasses.MISSING
            and f.default_factory is dataclasses.MISSING]
    if bare:
        return (f"{member} field(s) {', '.join(bare)} have no default; give each one, e.g. "
                f"param(1.0, \"what it does\")")
    try:
        typing.get_type_hints(cls)
    except Exception as exc:  # a hint naming what its module does not import
        return f"{member}'s type hints do not resolve ({type(exc).__name__}: {exc})"
    return None
