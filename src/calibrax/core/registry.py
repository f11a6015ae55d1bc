"""Finding plugins: the ``calibrax`` entry-point group (calibrax's own builtins first, then every
other distribution's) and ``CALIBRAX_PLUGINS``.

This is the one seam through which the core reaches a plugin: it names no module above it (the
builtins are entry points of the calibrax distribution, as a backend is of its own).

A plugin that fails to import (or whose hook raises) is reported as a warning naming its
distribution and the error, listed as broken by ``calibrax plugins``, and skipped; everything
else still works. ``CALIBRAX_PLUGINS=pkg.module,other.module`` registers modules that are not
installed as distributions (handy while writing a plugin, and for the test doubles).
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata as md
import os
import warnings
from dataclasses import dataclass, field

import pluggy

from calibrax.core import hookspecs
from calibrax.core.options import check_options
from calibrax.errors import PluginError

HOOKS = {
    "simulator": "calibrax_simulators",
    "metric": "calibrax_metrics",
    "acquisition": "calibrax_acquisitions",
    "executor": "calibrax_executors",
    "effect": "calibrax_effects",
    "verification": "calibrax_verifications",
}
#: the distribution whose entry points are the builtins, loaded before any other
BUILTIN_DISTRIBUTION = "calibrax"


class PluginWarning(UserWarning):
    """A plugin could not be loaded and was skipped."""


@dataclass(frozen=True)
class PluginInfo:
    """One registered plugin class."""

    kind: str
    name: str
    cls: type
    distribution: str
    version: str


@dataclass(frozen=True)
class BrokenPlugin:
    """A plugin that could not be loaded, and why."""

    entry_point: str
    distribution: str
    error: str


def _version(dist: str) -> str:
    try:
        return md.version(dist)
    except md.PackageNotFoundError:
        return "unknown"


@dataclass(eq=False)
class PluginManager:
    """The registry of every kind of plugin. Use :func:`get_manager` for the shared one."""

    pm: pluggy.PluginManager = field(default_factory=lambda: pluggy.PluginManager(hookspecs.PROJECT))
    broken: list[BrokenPlugin] = field(default_factory=list)
    _sources: dict[int, tuple[str, str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.pm.add_hookspecs(hookspecs)

    def register(self, plugin: object, name: str, distribution: str, version: str) -> None:
        """Register a module/object of hook implementations."""
        self.pm.register(plugin, name=name)
        self._sources[id(plugin)] = (distribution, version)

    def _skip(self, entry_point: str, distribution: str, exc: BaseException) -> None:
        error = f"{type(exc).__name__}: {exc}"
        self.broken.append(BrokenPlugin(entry_point, distribution, error))
        warnings.warn(f"calibrax plugin {entry_point!r} from {distribution} failed to load and is skipped: {error}",
                      PluginWarning, stacklevel=3)

    def load_builtins(self) -> None:
        """The builtin plugins: the entry points of the calibrax distribution itself. Without any
        (an install made before the builtins became entry points), warn with the fix."""
        before = len(self.pm.get_plugins())
        self.load_entry_points(only=BUILTIN_DISTRIBUTION)
        if len(self.pm.get_plugins()) == before:
            warnings.warn("calibrax's builtin plugins (metrics, acquisitions, executors, effects) are not registered: "
                          "its installed metadata predates them; reinstall it (`make setup`, or "
                          "`pip install -e .` in the checkout)", PluginWarning, stacklevel=2)

    def load_entry_points(self, only: str | None = None) -> None:
        """Every ``calibrax`` entry point (or only those of the distribution ``only``)."""
        for ep in md.entry_points(group=hookspecs.PROJECT):
            dist = ep.dist.name if ep.dist is not None else "unknown"
            if (only is not None and dist != only) or self.pm.has_plugin(ep.name):
                continue
            try:
                self.register(ep.load(), ep.name, dist, _version(dist))
            except Exception as exc:  # noqa: BLE001 — any import failure makes the plugin broken, not us
                self._skip(f"{ep.name} = {ep.value}", dist, exc)

    def load_env(self, variable: str = "CALIBRAX_PLUGINS") -> None:
        for module in filter(None, (m.strip() for m in os.environ.get(variable, "").split(","))):
            if self.pm.has_plugin(module):
                continue
            try:
                self.register(importlib.import_module(module), module, f"${variable}", "local")
            except Exception as exc:  # noqa: BLE001
                self._skip(module, f"${variable}", exc)

    @functools.cache
    def plugins(self, kind: str) -> dict[str, PluginInfo]:
        """{name: PluginInfo} of one kind; the first registration of a name wins (later ones warn)."""
        if kind not in HOOKS:
            raise PluginError(f"unknown plugin kind {kind!r}; kinds: {sorted(HOOKS)}")
        found: dict[str, PluginInfo] = {}
        for impl in reversed(getattr(self.pm.hook, HOOKS[kind]).get_hookimpls()):
            dist, version = self._sources.get(id(impl.plugin), ("unknown", "unknown"))
            try:
                classes = impl.function() or []
            except Exception as exc:  # noqa: BLE001
                self._skip(impl.plugin_name, dist, exc)
                continue
            for cls in classes:
                name = getattr(cls, "name", None)
                if not isinstance(name, str) or not name:
                    self._skip(impl.plugin_name, dist, PluginError(f"{cls!r} has no name"))
                    continue
                if name in found:
                    warnings.warn(f"{kind} {name!r} is registered by {found[name].distribution} and {dist}; "
                                  f"using {found[name].distribution}'s", PluginWarning, stacklevel=2)
                    continue
                found[name] = PluginInfo(kind, name, cls, dist, version)
        return found

    def get(self, kind: str, name: str) -> PluginInfo:
        """The plugin ``name`` of ``kind``, or a PluginError listing the known names."""
        known = self.plugins(kind)
        if name not in known:
            hint = ""
            if self.broken:
                hint = "; broken plugins: " + ", ".join(f"{b.entry_point} ({b.error})" for b in self.broken)
            raise PluginError(f"unknown {kind} {name!r}; known: {sorted(known)}{hint}")
        return known[name]

    def create(self, kind: str, name: str, **options: object) -> object:
        """An instance of plugin ``name`` built with ``options``, checked first against its declared
        ``OPTIONS`` (:func:`~calibrax.core.options.check_options`; errors name ``kind.option``)."""
        cls = self.get(kind, name).cls
        return cls(**check_options(kind, cls, options))


@functools.cache
def get_manager() -> PluginManager:
    """The process-wide manager: builtins, entry points, then ``CALIBRAX_PLUGINS``."""
    manager = PluginManager()
    manager.load_builtins()
    manager.load_entry_points()
    manager.load_env()
    return manager
