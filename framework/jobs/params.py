"""Parameters a job kind (or a plugin) declares: a dataclass whose fields carry their help.

Luigi-style: each job kind declares its own parameters, and the command line, the spec
validation and job.json are generated from the declaration. A field is declared with
:func:`param` (a number, a string or a flag, with a one-line help and optional bounds) or
:func:`plugin_param` (a plugin of some kind, chosen by name, whose own options nest under
it in the spec: ``"initialiser": {"name": "dce", "threshold": 1.0}``)::

    @dataclass
    class MyParams:
        steps: int = param(300, "Adam steps.", minimum=1, maximum=100_000)
        renderer: PluginChoice = plugin_param("renderer", "raster", "How strokes are drawn.")

The module imports no torch, so the command line can list parameters instantly.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from typing import Any

from inkmotion.errors import SpecError


@dataclass
class PluginChoice:
    """A plugin chosen by name, with its own options (``{"name": ..., **options}``)."""

    kind: str
    name: str
    options: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, **self.options}


def param(default: Any, help: str, *, minimum: float | None = None,
          maximum: float | None = None, choices: tuple[str, ...] | None = None,
          flag: str | None = None, earlier: dict[int, Any] | None = None,
          file: bool = False) -> Any:
    """A parameter field: its default, one line of help, optional bounds and choices.

    ``flag`` names the command-line option when it should differ from ``--field-name``.
    ``file``: the value names a file, which the command line records as an absolute path
    (so ``run --config job.json`` reproduces the job from any folder).
    ``earlier``: the defaults of older spec versions where they differ, ``{version: value}``
    (a version takes the value of the nearest listed version at or above it, else
    ``default``, :func:`default_for`), so a job.json of an older version that leaves the
    field out runs as it did. The default and its history are written here only.
    """
    meta = {"help": help, "minimum": minimum, "maximum": maximum, "choices": choices,
            "flag": flag, "earlier": dict(earlier or {}), "file": file}
    return field(default=default, metadata=meta)


def redefault(base: type, name: str, default: Any, help: str | None = None) -> Any:
    """The field ``name`` of the parameters dataclass ``base`` (its help, bounds, flag)
    with another default, for a kind that shares ``base``'s parameters but not all their
    defaults; the base field's ``earlier`` defaults are the base's own history, not
    carried over."""
    base_field = {f.name: f for f in dataclasses.fields(base)}[name]
    meta = {**base_field.metadata, "earlier": {}}
    if help is not None:
        meta["help"] = help
    return field(default=default, metadata=meta)


def default_for(f: dataclasses.Field, version: int | None) -> tuple[bool, Any]:
    """(whether spec ``version`` had another default for the field ``f``, that default),
    from its ``earlier`` history (:func:`param`); None: the current version."""
    earlier = f.metadata.get("earlier") or {}
    listed = sorted(v for v in earlier if version is not None and v >= version)
    if not listed:
        return False, None
    return True, earlier[listed[0]]


def plugin_param(kind: str, default: str | None, help: str, *, many: bool = False,
                 flag: str | None = None) -> Any:
    """A parameter naming a plugin of ``kind`` (``many``: a list of them, e.g. losses).

    ``default`` None means "none chosen" (e.g. the reader: the first that accepts the input).
    """
    meta = {"help": help, "plugin_kind": kind, "many": many, "flag": flag}
    if many:
        names = [default] if default else []
        return field(default_factory=lambda: [PluginChoice(kind, n) for n in names],
                     metadata=meta)
    if default is None:
        return field(default=None, metadata=meta)
    return field(default_factory=lambda: PluginChoice(kind, default), metadata=meta)


def number_text(x: float | None) -> str:
    """A bound as a person reads it: a whole number in full, others as ``:g`` gives."""
    if x is None:
        return ""
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


@dataclass(frozen=True)
class ParamInfo:
    """One declared parameter, as the command line and the validation see it."""

    name: str
    type: Any  # int, float, bool, str, or PluginChoice
    default: Any
    help: str
    optional: bool = False  # None is allowed
    minimum: float | None = None
    maximum: float | None = None
    choices: tuple[str, ...] | None = None
    plugin_kind: str | None = None
    many: bool = False
    flag: str | None = None
    file: bool = False  # the value names a file

    @property
    def option(self) -> str:
        """The command-line flag, e.g. ``--lambda-smooth``."""
        from inkmotion.plugin_host.protocols import field_flag

        return field_flag(self.name, self.flag)


def describe(cls: type) -> list[ParamInfo]:
    """The parameters a dataclass declares, in declaration order."""
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        meta = f.metadata
        base, optional = _base_type(hints[f.name])
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            default = None
        out.append(ParamInfo(
            name=f.name, type=base, default=default, help=meta.get("help", ""),
            optional=optional, minimum=meta.get("minimum"), maximum=meta.get("maximum"),
            choices=meta.get("choices"), plugin_kind=meta.get("plugin_kind"),
            many=bool(meta.get("many")), flag=meta.get("flag"), file=bool(meta.get("file"))))
    return out


def _base_type(hint: Any) -> tuple[Any, bool]:
    """(the field's scalar type, whether None is allowed) from a type hint."""
    args = typing.get_args(hint)
    optional = type(None) in args
    if optional:
        hint = next(a for a in args if a is not type(None))
        args = typing.get_args(hint)
    if typing.get_origin(hint) is list:
        return args[0], optional
    return hint, optional


def parse(cls: type, raw: Any, source: str, what: str = "parameter",
          version: int | None = None) -> Any:
    """An instance of the dataclass ``cls`` from a JSON object; a bad or unknown field
    raises :class:`SpecError` naming it, the source and what is allowed. ``version``: the
    spec version the object was written for; a field it leaves out takes that version's
    default (:func:`default_for`)."""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise SpecError(f"{source}: the {what}s must be a JSON object, got {type(raw).__name__}.")
    infos = {i.name: i for i in describe(cls)}
    unknown = sorted(set(raw) - set(infos))
    if unknown:
        raise SpecError(f"{source}: unknown {what}(s) {', '.join(unknown)}; known {what}s are "
                        f"{', '.join(infos) or 'none'}.")
    values = {name: _value(infos[name], value, source) for name, value in raw.items()}
    for f in dataclasses.fields(cls):
        older, value = default_for(f, version)
        if older and f.name not in values:
            values[f.name] = _value(infos[f.name], value, source)
    return cls(**values)


def _value(info: ParamInfo, value: Any, source: str) -> Any:
    """One field's value, checked against its declaration."""
    if value is None:
        if info.optional:
            return None
        raise SpecError(f"{source}: {info.name} must be given (it cannot be null).")
    if info.plugin_kind is not None:
        if info.many:
            items = value if isinstance(value, list) else [value]
            return [_choice(info, v, source) for v in items]
        return _choice(info, value, source)
    return check_scalar(info, value, source)


def check_scalar(info: ParamInfo, value: Any, source: str = "job spec") -> Any:
    """A number, string or flag checked against type, bounds and choices."""
    name = info.name
    if info.type is bool:
        if not isinstance(value, bool):
            raise SpecError(f"{source}: {name}={value!r} must be true or false.")
        return value
    if info.type in (int, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SpecError(f"{source}: {name}={value!r} must be a number.")
        if info.type is int and not float(value).is_integer():
            raise SpecError(f"{source}: {name}={value!r} must be a whole number.")
        if not math.isfinite(value):
            raise SpecError(f"{source}: {name}={value!r} must be a finite number.")
        value = info.type(value)
        lo, hi = info.minimum, info.maximum
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            lo_t, hi_t = number_text(lo), number_text(hi)
            bounds = (f"between {lo_t} and {hi_t}" if lo is not None and hi is not None
                      else f"at least {lo_t}" if lo is not None else f"at most {hi_t}")
            raise SpecError(f"{source}: {name}={value!r} must be {bounds}.")
        return value
    if not isinstance(value, str):
        raise SpecError(f"{source}: {name}={value!r} must be a string.")
    if info.choices and value not in info.choices:
        raise SpecError(f"{source}: {name}={value!r} must be one of {', '.join(info.choices)}.")
    return value


def _choice(info: ParamInfo, value: Any, source: str) -> PluginChoice:
    """``"name"`` or ``{"name": ..., **options}`` -> a :class:`PluginChoice` (options are
    checked against the plugin's own declaration by :func:`check_plugin_options`)."""
    if isinstance(value, PluginChoice):
        return value
    if isinstance(value, str):
        return PluginChoice(info.plugin_kind or "", value)
    if isinstance(value, dict) and isinstance(value.get("name"), str):
        options = {k: v for k, v in value.items() if k != "name"}
        return PluginChoice(info.plugin_kind or "", value["name"], options)
    raise SpecError(f"{source}: {info.name} must name one of the {info.plugin_kind} plugins, as "
                    f"\"NAME\" or {{\"name\": \"NAME\", ...options}}; got {value!r}.")


def to_dict(params: Any) -> dict[str, Any]:
    """The JSON form of a parameters dataclass (plugins as ``{"name": ..., **options}``)."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        if isinstance(value, PluginChoice):
            value = value.to_dict()
        elif isinstance(value, list):
            value = [v.to_dict() if isinstance(v, PluginChoice) else v for v in value]
        out[f.name] = value
    return out


def plugin_options(plugin: Any, choice: PluginChoice, source: str,
                   version: int | None = None) -> Any:
    """The plugin's options dataclass filled from ``choice.options`` (checked; options left
    out take spec ``version``'s defaults), or a plain dict when the plugin declares none
    (then no options are allowed)."""
    cls = getattr(plugin, "Options", None)
    if cls is None:
        if choice.options:
            raise SpecError(f"{source}: the {choice.kind} plugin {choice.name!r} takes no "
                            f"options; remove {', '.join(sorted(choice.options))}.")
        return None
    return parse(cls, choice.options, f"{source}: {choice.kind} {choice.name!r}", "option",
                 version)


def options_dict(options: Any) -> dict[str, Any]:
    """Keyword arguments from a plugin's parsed options (``{}`` for none)."""
    return {} if options is None else to_dict(options)
