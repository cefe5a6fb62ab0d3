"""The plugin manager: loads plugins from the ``inkmotion`` entry-point group.

Built-ins are registered exactly like third-party plugins (through entry points), so
nothing in the core knows a built-in by name except as a default. A plugin module that
fails to import is recorded as broken and skipped; ``inkmotion plugins`` reports it.
``check_pending()`` runs after loading, so a misspelt hook fails loudly and early.
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

ENTRY_POINT_GROUP = "inkmotion"


@dataclass(frozen=True)
class PluginInfo:
    """One row of ``inkmotion plugins``."""

    kind: str
    name: str
    origin: str  # distribution name and module, e.g. "inkmotion (inkmotion.plugins.gml)"
    description: str
    error: str | None = None  # set when the plugin failed to load


class PluginHost:
    """Owns one :class:`pluggy.PluginManager` and the broken-plugin records."""

    def __init__(self) -> None:
        self.pm = pluggy.PluginManager(PROJECT)
        self.pm.add_hookspecs(hookspecs)
        self.broken: list[PluginInfo] = []
        self._origins: dict[int, str] = {}
        self._by_kind: dict[str, dict[str, Any]] = {}

    def load_entry_points(self, group: str = ENTRY_POINT_GROUP) -> None:
        """Import and register every module of the entry-point group.

        A module that fails to import, or whose hooks do not match the specs (a misspelt
        hook name, wrong arguments), is recorded as broken with the reason and skipped,
        with a warning, so one bad third-party plugin cannot take the command line down.
        """
        for ep in sorted(entry_points(group=group), key=lambda e: e.name):
            dist = ep.dist.name if ep.dist is not None else "?"
            origin = f"{dist} ({ep.value})"
            try:
                module = ep.load()
                self.register(module, name=ep.name, origin=origin)
            except Exception as exc:  # a broken plugin must not take the host down
                error = f"{type(exc).__name__}: {exc}"
                self.broken.append(PluginInfo("?", ep.name, origin, "failed to load", error))
                warnings.warn(f"inkmotion plugin {ep.name!r} from {origin} was skipped: {error}",
                              stacklevel=2)

    def register(self, module: Any, name: str | None = None, origin: str = "local") -> None:
        """Register a plugin module or object; its hooks are verified against the specs
        (pluggy checks the arguments, ``check_pending`` rejects hooks with no spec)."""
        try:
            self.pm.register(module, name=name)
        except pluggy.PluginValidationError as exc:
            raise PluginError(f"Plugin {name or module!r} has an invalid hook: {exc}") from exc
        try:
            self.pm.check_pending()
        except pluggy.PluginValidationError as exc:
            self.pm.unregister(module)
            raise PluginError(f"Plugin {name or module!r} implements a hook that does not "
                              f"exist: {exc}") from exc
        self._origins[id(module)] = origin
        self._by_kind.clear()

    def plugins(self, kind: str) -> dict[str, Any]:
        """All plugin objects of ``kind``, by name (collected once per registration state)."""
        if kind not in KIND_HOOKS:
            raise PluginError(
                f"Unknown plugin kind {kind!r}; kinds are: {', '.join(sorted(KIND_HOOKS))}."
            )
        if kind not in self._by_kind:
            hook = getattr(self.pm.hook, KIND_HOOKS[kind])
            found: dict[str, Any] = {}
            for impl in hook.get_hookimpls():
                for obj in impl.function() or []:
                    obj._inkmotion_origin = self._origins.get(id(impl.plugin), "local")
                    found[obj.name] = obj
            self._by_kind[kind] = found
        return self._by_kind[kind]

    def get(self, kind: str, name: str) -> Any:
        """The plugin object ``name`` of ``kind``; a clear error lists the available ones."""
        available = self.plugins(kind)
        if name in available:
            return available[name]
        broken = [b for b in self.broken if b.name == name]
        if broken:
            raise PluginError(f"The {kind} plugin {name!r} failed to load ({broken[0].error}).")
        names = ", ".join(sorted(available)) or "none"
        raise PluginError(f"Unknown {kind} plugin {name!r}; available: {names}.")

    def table(self) -> list[PluginInfo]:
        """Every plugin with kind, name, origin and one-line description, broken ones last."""
        rows = [
            PluginInfo(kind, obj.name, getattr(obj, "_inkmotion_origin", "local"),
                       obj.description.strip().splitlines()[0] if obj.description else "")
            for kind in KIND_HOOKS
            for obj in self.plugins(kind).values()
        ]
        return rows + self.broken


@functools.lru_cache(maxsize=1)
def host() -> PluginHost:
    """The process-wide plugin host (the one piece of global state), loaded on first use."""
    h = PluginHost()
    h.load_entry_points()
    return h


def plugin(kind: str, name: str) -> Any:
    """The registered plugin object ``name`` of ``kind``, e.g. ``plugin("renderer", "raster")``."""
    return host().get(kind, name)
