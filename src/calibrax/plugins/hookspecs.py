"""The hook specifications, kept importable here for plugins written against this path; they live
in :mod:`calibrax.core.hookspecs`."""

from calibrax.core.hookspecs import (PROJECT, calibrax_acquisitions, calibrax_effects, calibrax_executors,
                                     calibrax_metrics, calibrax_simulators, calibrax_verifications, hookimpl, hookspec)

__all__ = ["PROJECT", "hookimpl", "hookspec", "calibrax_simulators", "calibrax_metrics", "calibrax_acquisitions",
           "calibrax_executors", "calibrax_effects", "calibrax_verifications"]
