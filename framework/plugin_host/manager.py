"""The plugin manager: loads plugins from the ``inkmotion`` entry-point group.

Built-ins are registered exactly like third-party plugins (through entry points), so
nothing in the core knows a built-in by name except as a default. Registration is checked
in full before anything is kept (pluggy's ``check_pending`` for misspelt hooks, the
objects each hook returns against their kind's protocol, names unique per kind): a plugin
that fails any check is unregistered again, recorded as broken with the reason, and
``inkmotion plugins`` reports it; one bad third-party plugin never takes the command line
down. Loading the built-ins imports no torch (their heavy parts load on first use).

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
from inkmotion.plugin_host.protocols import check_plugin_object

ENTRY_POINT_GROUP = "inkmotion"
#: comma-separated entry-point names of plugins not to load (module docstring)
DISABLE_ENV = "INKMOTION_DISABLE_PLUGINS"


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

    def load_entry_points(self, group: str = ENTRY_POINT_GROUP) -> None:
        """Import and register every module of the entry-point group.

        A module that fails to import or to register (a misspelt hook, wrong arguments, an
        object that breaks its protocol, a name another package already registered) is
        recorded as broken with the reason and skipped, with a warning.
        """
        import os

        blocked = {n.strip() for n in os.environ.get(DISABLE_ENV, "").split(",") if n.strip()}
        for name in blocked:
            self.pm.set_blocked(name)
        found = sorted(entry_points(group=group), key=lambda e: e.name)
        unknown = sorted(blocked - {ep.name for ep in found})
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
                error = f"{type(exc).__name__}: {exc}"
                self.broken.append(PluginInfo("?", ep.name, origin, "failed to load", error))
                warnings.warn(f"inkmotion plugin {ep.name!r} from {origin} was skipped: {error}",
                              stacklevel=2)

    def register(self, module: Any, name: str | None = None, origin: str = "local") -> None:
        """Register a plugin module or object, all or nothing.

        pluggy verifies the hooks' arguments; ``check_pending`` rejects hooks with no spec;
        every object a hook returns is checked against its kind's protocol; a name already
        taken within a kind is refused, naming both origins. On any failure the module is
        unregistered again and :class:`PluginError` says why.
        """
        label = name or getattr(module, "__name__", repr(module))
        try:
            self.pm.register(module, name=name)
        except pluggy.PluginValidationError as exc:
            raise PluginError(f"Plugin {label!r} from {origin} has an invalid hook: "
                              f"{_one_line(exc)}") from exc
        except ValueError as exc:  # registered twice under one name
            raise PluginError(f"Plugin {label!r} from {origin}: {exc}") from exc
        try:
            self.pm.check_pending()
            found = self._collect(module, label, origin)
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

    def _collect(self, module: Any, label: str, origin: str) -> list[tuple[str, Any]]:
        """The (kind, object) pairs ``module``'s hooks provide, each checked; raises
        :class:`PluginError` on the first problem, before anything is kept."""
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
        return found

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
        off = [d for d in self.disabled if d.name == name]
        if off:
            raise PluginError(f"The {kind} plugin {name!r} is switched off by {DISABLE_ENV}; "
                              f"remove it from there or choose another: "
                              f"{', '.join(sorted(available)) or 'none'}.")
        broken = [b for b in self.broken if b.name == name]
        if broken:
            raise PluginError(f"The {kind} plugin {name!r} failed to load ({broken[0].error}).")
        names = ", ".join(sorted(available)) or "none"
        failed = ""
        if self.broken:  # the one asked for may be among them, under its entry-point name
            shown = ", ".join(f"{b.name!r} from {b.origin}" for b in self.broken)
            failed = (f" {len(self.broken)} plugin package(s) failed to load and may hold it: "
                      f"{shown}; `inkmotion plugins` says why.")
        raise PluginError(f"Unknown {kind} plugin {name!r}; available: {names}.{failed}")

    def table(self) -> list[PluginInfo]:
        """Every plugin with kind, name, origin and one-line description, broken ones last."""
        rows = [
            PluginInfo(kind, obj.name, self._origins.get((kind, obj.name), "local"),
                       obj.description.strip().splitlines()[0] if obj.description else "")
            for kind in KIND_HOOKS
            for obj in self.plugins(kind).values()
        ]
        return rows + self.broken + self.disabled


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
