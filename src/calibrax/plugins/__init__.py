"""The plugin system: hook specifications, the manager, and the builtin plugins."""

from calibrax.core.hookspecs import hookimpl, hookspec

__all__ = ["hookimpl", "hookspec"]
