"""Plugin host: hookspecs, protocols and the entry-point based manager.

The names load on first use (PEP 562), so an engine that imports
:mod:`inkmotion.plugin_host.protocols` for its type hints imports neither pluggy nor the
manager.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inkmotion.lazy import lazy_names

if TYPE_CHECKING:  # what type checkers and IDEs see; at run time __getattr__ loads them
    from inkmotion.plugin_host.hookspecs import KIND_HOOKS, hookimpl, hookspec
    from inkmotion.plugin_host.manager import PluginHost, PluginInfo, host, plugin

#: public name -> the module that defines it
_PUBLIC = {
    "KIND_HOOKS": "inkmotion.plugin_host.hookspecs",
    "hookimpl": "inkmotion.plugin_host.hookspecs",
    "hookspec": "inkmotion.plugin_host.hookspecs",
    "PluginHost": "inkmotion.plugin_host.manager",
    "PluginInfo": "inkmotion.plugin_host.manager",
    "host": "inkmotion.plugin_host.manager",
    "plugin": "inkmotion.plugin_host.manager",
}

__all__ = ["KIND_HOOKS", "PluginHost", "PluginInfo", "hookimpl", "hookspec", "host", "plugin"]

__getattr__, __dir__ = lazy_names(__name__, _PUBLIC, globals(), __all__)
