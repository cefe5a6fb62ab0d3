"""Plugin host: hookspecs, protocols and the entry-point based manager."""

from inkmotion.plugin_host.hookspecs import KIND_HOOKS, hookimpl, hookspec
from inkmotion.plugin_host.manager import PluginHost, PluginInfo, host, plugin

__all__ = ["KIND_HOOKS", "PluginHost", "PluginInfo", "hookimpl", "hookspec", "host", "plugin"]
