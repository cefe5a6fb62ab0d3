"""The plugin manager: loads plugins from the ``inkmotion`` entry-point group.

Built-ins are registered exactly like third-party plugins (through entry points), so
nothing in the core knows a built-in by name except as a default. Registration is checked
in full before anything is kept (pluggy's ``check_pending`` for misspelt hooks, the
objects each hook returns against their kind's protocol, names unique per kind, command-line
flags unique: a plugin option's ``--PLUGIN-OPTION`` is nobody else's flag): a plugin
that fails any check is unregistered again, recorded as broken with the reason, and
``inkmotion plugins`` reports it; one bad third-party plugin never takes the command line
down. The built-ins load first, so a clash of names or flags is always the third-party
plugin's, refused, whatever its entry point is called. Loading the built-ins imports no
torch (their heavy parts load on first use).

A user switches plugins off by entry-point name (the module names ``inkmotion plugins``
shows in its origin column, e.g. ``raster`` for ``inkmotion.plugins.raster``) in
``INKMOTION_DISABLE_PLUGINS`` (comma-separated), like pluggy's ``set_blocked``: a blocked
module is never imported, so a third-party plugin can take the name of a built-in.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any

import pluggy

from inkmotion.errors import PluginError
from inkmotion.plugin_host import hookspecs
from inkmotion.plugin_host.hookspecs import KIND_HOOKS, PROJECT
from inkmotion.plugin_host.protocols import check_plugin_object, field_flag, option_flag

ENTRY_POINT_GROUP = "inkmotion"
#: the distribution of the built-in plugins (loaded before any other package's)
BUILT_IN = "inkmotion"
#: comma-separated entry-point names of plugins not to load (module docstring)
DISABLE_ENV = "INKMOTION_DISABLE_PLUGINS"
#: set to 1: a third-party plugin's failure shows its traceback (:func:`plugin_at_fault`)
TRACEBACK_ENV = "INKMOTION_TRACEBACK"


@dataclass(frozen=True)
class PluginInfo:
    """One row of ``inkmotion plugins``."""

    kind: str
    name: str
    origin: str  # distribution name and module, e.g. "inkmotion (inkmotion.plugins.gml)"
    description: str
    error: str | None = None  # set when the plugin failed to load


class PluginHost:
    """Owns one :class:`pluggy.PluginManager`, the plugin objects by kind and name, and
    the broken-plugin records."""

    def __init__(self) -> None:
        self.pm = pluggy.PluginManager(PROJECT)
        self.pm.add_hookspecs(hookspecs)
        self.broken: list[PluginInfo] = []
        self._objects: dict[str, dict[str, Any]] = {kind: {} for kind in KIND_HOOKS}
        self._origins: dict[tuple[str, str], str] = {}  # (kind, name) -> origin
        self.disabled: list[PluginInfo] = []  # blocked by DISABLE_ENV, never imported
        #: command-line flag -> the kind and the words naming who declares it
        self._flags: dict[str, tuple[str, str]] = {}

    def load_entry_points(self, group: str = ENTRY_POINT_GROUP) -> None:
        """Import and register every module of the entry-point group.

        A module that fails to import or to register (a misspelt hook, wrong arguments, an
        object that breaks its protocol, a name another package already registered) is
        recorded as broken with the reason and skipped, with a warning.
        """
        import os

        given = {n.strip() for n in os.environ.get(DISABLE_ENV, "").split(",") if n.strip()}
        found = sorted(entry_points(group=group), key=lambda e: (
            e.dist is None or e.dist.name != BUILT_IN, e.name))
        # a plugin is named by its entry point, or by the module `inkmotion plugins` shows
        # in its origin column (in full or its last part); an entry-point name always wins
        aliases: dict[str, str] = {}
        for ep in found:
            module = ep.value.split(":")[0]
            aliases.setdefault(module, ep.name)
            aliases.setdefault(module.rsplit(".", 1)[-1], ep.name)
        aliases.update({ep.name: ep.name for ep in found})
        blocked = {aliases.get(name, name) for name in given}
        for name in blocked:
            self.pm.set_blocked(name)
        unknown = sorted(name for name in given if name not in aliases)
        if unknown and group == ENTRY_POINT_GROUP:
            warnings.warn(f"{DISABLE_ENV} names {', '.join(map(repr, unknown))}, which no "
                          f"installed plugin has; entry points are: "
                          f"{', '.join(ep.name for ep in found)}.", stacklevel=2)
        for ep in found:
            dist = ep.dist.name if ep.dist is not None else "?"
            origin = f"{dist} ({ep.value})"
            if self.pm.is_blocked(ep.name):
                self.disabled.append(PluginInfo("?", ep.name, origin, "disabled",
                                                f"disabled by {DISABLE_ENV}"))
                continue
            try:
                module = ep.load()
                self.register(module, name=ep.name, origin=origin)
            except Exception as exc:  # a broken plugin must not take the host down
                error = str(exc) if isinstance(exc, PluginError) else \
                    f"{type(exc).__name__}: {exc}"
                self.broken.append(PluginInfo("?", ep.name, origin, "failed to load", error))
                warnings.warn(f"inkmotion skipped a plugin: {error}"
                              if isinstance(exc, PluginError) else
                              f"inkmotion plugin {ep.name!r} from {origin} was skipped: {error}",
                              stacklevel=2)

    def register(self, module: Any, name: str | None = None, origin: str = "local") -> None:
        """Register a plugin module or object, all or nothing.

        pluggy verifies the hooks' arguments; ``check_pending`` rejects hooks with no spec;
        every object a hook returns is checked against its kind's protocol; a name already
        taken within a kind, or a command-line flag already taken (:func:`command_flags`),
        is refused, naming both. On any failure the module is unregistered again and
        :class:`PluginError` says why.
        """
        label = name or getattr(module, "__name__", repr(module))
        try:
            self.pm.register(module, name=name)
        except pluggy.PluginValidationError as exc:
            raise PluginError(f"Plugin {label!r} from {origin} has an invalid hook: "
                              f"{_one_line(exc)}") from exc
        except ValueError as exc:  # registered twice under one name (pluggy then lists all)
            first = str(exc).splitlines()[0].split("=<")[0]
            raise PluginError(f"Plugin {label!r} from {origin}: {first}.") from exc
        try:
            self.pm.check_pending()
            found, flags = self._collect(module, label, origin)
        except pluggy.PluginValidationError as exc:
            self.pm.unregister(module)
            raise PluginError(f"Plugin {label!r} from {origin} implements a hook that does "
                              f"not exist: {_one_line(exc)}") from exc
        except Exception:
            self.pm.unregister(module)
            raise
        for kind, obj in found:
            obj._inkmotion_origin = origin
            self._objects[kind][obj.name] = obj
            self._origins[(kind, obj.name)] = origin
        self._flags.update(flags)

    def _collect(self, module: Any, label: str, origin: str
                 ) -> tuple[list[tuple[str, Any]], dict[str, tuple[str, str]]]:
        """The (kind, object) pairs ``module``'s hooks provide, each checked, and the flags
        they add (:attr:`_flags`'s form); raises :class:`PluginError` on the first
        problem, before anything is kept."""
        found: list[tuple[str, Any]] = []
        seen: set[tuple[str, str]] = set()
        for kind, hook_name in KIND_HOOKS.items():
            hook = getattr(self.pm.hook, hook_name)
            for impl in hook.get_hookimpls():
                if impl.plugin is not module:
                    continue
                try:
                    objects = impl.function() or []
                except Exception as exc:
                    raise PluginError(f"Plugin {label!r} from {origin}: {hook_name}() raised "
                                      f"{type(exc).__name__}: {exc}") from exc
                if not isinstance(objects, (list, tuple)):
                    raise PluginError(f"Plugin {label!r} from {origin}: {hook_name}() returned "
                                      f"{type(objects).__name__}; return a list of plugin "
                                      f"objects, e.g. [{type(objects).__name__}()].")
                for obj in objects:
                    problem = check_plugin_object(kind, obj)
                    if problem:
                        raise PluginError(f"Plugin {label!r} from {origin}: {problem}.")
                    key = (kind, obj.name)
                    if key in self._origins or key in seen:
                        first = self._origins.get(key, origin)
                        raise PluginError(
                            f"Two {kind} plugins are named {obj.name!r}: one from {first}, "
                            f"one from {origin}; uninstall or rename one of them.")
                    seen.add(key)
                    found.append((kind, obj))
        added: dict[str, tuple[str, str]] = {}
        for kind, obj in found:
            who = f"the {_what(kind)} {obj.name!r} from {origin}"
            for flag in command_flags(kind, obj):
                owner_kind, owner = added.get(flag) or self._flags.get(flag) or (None, "")
                # job kinds share flags (each is its own command), nobody else does
                if owner_kind is not None and not (kind == owner_kind == "job-kind"):
                    raise PluginError(
                        f"Plugin {label!r} from {origin}: {who} would take the flag {flag}, "
                        f"which {owner} already has; rename the option or the plugin.")
                if owner_kind is None:
                    added[flag] = (kind, who)
        return found, added

    def plugins(self, kind: str) -> dict[str, Any]:
        """All plugin objects of ``kind``, by name."""
        if kind not in KIND_HOOKS:
            raise PluginError(
                f"Unknown plugin kind {kind!r}; kinds are: {', '.join(sorted(KIND_HOOKS))}."
            )
        return self._objects[kind]

    def get(self, kind: str, name: str) -> Any:
        """The plugin object ``name`` of ``kind``; a clear error lists the available ones."""
        available = self.plugins(kind)
        if name in available:
            return available[name]
        what = _what(kind)
        off = [d for d in self.disabled if d.name == name]
        if off:
            raise PluginError(f"The {what} {name!r} is switched off by {DISABLE_ENV}; "
                              f"remove it from there or choose another: "
                              f"{', '.join(sorted(available)) or 'none'}.")
        broken = [b for b in self.broken if b.name == name]
        if broken:
            raise PluginError(f"The {what} {name!r} failed to load ({broken[0].error}).")
        names = ", ".join(sorted(available)) or "none"
        failed = ""
        if self.broken:  # the one asked for may be among them, under its entry-point name
            shown = ", ".join(f"{b.name!r} from {b.origin}" for b in self.broken)
            failed = (f" {len(self.broken)} plugin package(s) failed to load and may hold it: "
                      f"{shown}; `inkmotion plugins` says why.")
        if self.disabled:
            off_names = ", ".join(repr(d.name) for d in self.disabled)
            failed += f" {DISABLE_ENV} switches off {off_names}, which may hold it."
        raise PluginError(f"Unknown {what} {name!r}; available: {names}.{failed}")

    def table(self) -> list[PluginInfo]:
        """Every plugin with kind, name, origin and one-line description, broken ones last."""
        rows = [
            PluginInfo(kind, obj.name, self._origins.get((kind, obj.name), "local"),
                       obj.description.strip().splitlines()[0] if obj.description else "")
            for kind in KIND_HOOKS
            for obj in self.plugins(kind).values()
        ]
        return rows + self.broken + self.disabled


def distribution(obj: Any) -> str:
    """The distribution a registered plugin object came from (its origin's first word:
    "inkmotion" for a built-in), "local" for one registered by hand."""
    return str(getattr(obj, "_inkmotion_origin", "local")).split(" (")[0]


def is_built_in(obj: Any) -> bool:
    """Whether plugin object ``obj`` came with inkmotion itself (its entry points)."""
    return distribution(obj) == BUILT_IN


def plugin_at_fault(exc: BaseException) -> str | None:
    """One sentence naming the third-party plugin whose code raised ``exc`` (the innermost
    frame of its traceback in the package of a plugin object from another distribution
    than inkmotion), or None when no such plugin is in it: the fault is then inkmotion's
    own, and its traceback the report to file. Only an already loaded host is asked."""
    if host.cache_info().currsize == 0:
        return None
    h = host()
    by_module: dict[str, list[tuple[str, Any]]] = {}  # module -> its (kind, object)s
    for kind in KIND_HOOKS:
        for obj in h.plugins(kind).values():
            if not is_built_in(obj):
                by_module.setdefault(type(obj).__module__, []).append((kind, obj))
    tb, found = exc.__traceback__, None
    while tb is not None:
        module = str(tb.tb_frame.f_globals.get("__name__", ""))
        found = _plugin_of_frame(tb.tb_frame, by_module.get(module, [])) or found
        tb = tb.tb_next
    if found is None:
        return None
    culprit = (f"the {_what(found[0])} {found[1].name!r} from "
               f"{getattr(found[1], '_inkmotion_origin', '?')}" if isinstance(found, tuple)
               else f"a plugin of {found}")
    return (f"{culprit} failed: {type(exc).__name__}: {_one_line(exc)}; this is a fault of "
            f"that plugin, not of your input: tell its authors, or choose another plugin "
            f"(`inkmotion plugins` lists them; {TRACEBACK_ENV}=1 shows the traceback).")


def _plugin_of_frame(frame: Any, candidates: list[tuple[str, Any]]
                     ) -> tuple[str, Any] | str | None:
    """Which of ``candidates`` (the plugin objects of the frame's module) the frame runs:
    the one that is its ``self``, or whose class its function is defined in (a closure
    a method returned included); the only one of its module; else the module's origin
    (several plugins share it), or None when the module holds no plugin."""
    if not candidates:
        return None
    qualname = getattr(frame.f_code, "co_qualname", "")
    for kind, obj in candidates:
        if frame.f_locals.get("self") is obj or qualname.startswith(
                type(obj).__qualname__ + "."):
            return kind, obj
    if len(candidates) == 1:
        return candidates[0]
    return str(getattr(candidates[0][1], "_inkmotion_origin", "?"))


def command_flags(kind: str, obj: Any) -> list[str]:
    """The command-line flags ``obj`` declares: a job kind's parameters (``--lambda-smooth``),
    any other plugin's options as ``--PLUGIN-OPTION`` (``--dce-relevance``), switches
    with their ``--no-`` form too. A ``run KIND`` command takes the kind's flags and those
    of every plugin it can choose, so a plugin option's flag must be nobody else's (job
    kinds may share theirs: each is a command of its own)."""
    import dataclasses
    import typing

    cls = obj.Params if kind == "job-kind" else getattr(obj, "Options", None)
    if cls is None:
        return []
    hints = typing.get_type_hints(cls)
    flags = []
    for f in dataclasses.fields(cls):
        flag = (field_flag(f.name, f.metadata.get("flag")) if kind == "job-kind"
                else option_flag(obj.name, f.name))
        flags.append(flag)
        if hints.get(f.name) in (bool, typing.Optional[bool]):  # noqa: UP045
            flags.append("--no-" + flag[2:])
    return flags


def _what(kind: str) -> str:
    """How a sentence names a plugin of ``kind``: "job kind", "image-loss plugin"."""
    return "job kind" if kind == "job-kind" else f"{kind} plugin"


def _one_line(exc: BaseException) -> str:
    """pluggy's multi-line validation message as one line."""
    return "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())


@functools.lru_cache(maxsize=1)
def host() -> PluginHost:
    """The process-wide plugin host (the one piece of global state), loaded on first use."""
    h = PluginHost()
    h.load_entry_points()
    return h


def plugin(kind: str, name: str) -> Any:
    """The registered plugin object ``name`` of ``kind``, e.g. ``plugin("renderer", "raster")``."""
    return host().get(kind, name)
