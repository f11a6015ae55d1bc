"""Hook specifications: one hook per kind of plugin (the interfaces every plugin implements;
``calibrax.hookimpl`` and ``calibrax.plugins.hookimpl`` are the same marker).

A plugin is a module (or object) with functions marked ``@calibrax.hookimpl`` that return a list
of *classes* of the kind; each class has a ``name`` attribute that users write in campaign files.
Register it through the entry-point group ``calibrax``::

    [project.entry-points.calibrax]
    my_backend = "my_package.plugin"
"""

from __future__ import annotations

import pluggy

PROJECT = "calibrax"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def calibrax_simulators() -> list[type]:
    """Simulator classes (see :class:`calibrax.core.simulator.Simulator`), built with no arguments."""


@hookspec
def calibrax_metrics() -> list[type]:
    """Metric classes (see :class:`calibrax.core.search.metric.Metric`), built with the metric's options."""


@hookspec
def calibrax_acquisitions() -> list[type]:
    """Acquisition classes (see :class:`calibrax.core.search.acquisition.Acquisition`)."""


@hookspec
def calibrax_executors() -> list[type]:
    """Executor classes (see :class:`calibrax.core.running.executor.Executor`)."""


@hookspec
def calibrax_verifications() -> list[type]:
    """Verification classes (see :class:`calibrax.core.sheartest.verification.Verification`): a backend's
    analytic checks, each class named after the simulator it verifies, built with no arguments."""


@hookspec
def calibrax_effects() -> list[type]:
    """Candidate unmodelled effects for ``calibrax diagnose`` (wall friction, size distribution, …)."""
