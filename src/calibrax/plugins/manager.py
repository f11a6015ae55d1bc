"""The plugin manager, kept importable here; it lives in :mod:`calibrax.core.registry`."""

from calibrax.core.registry import HOOKS, BrokenPlugin, PluginInfo, PluginManager, PluginWarning, get_manager

__all__ = ["HOOKS", "BrokenPlugin", "PluginInfo", "PluginManager", "PluginWarning", "get_manager"]
