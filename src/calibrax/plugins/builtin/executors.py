"""Builtin executor ``local``: a process per simulation on this machine."""

from __future__ import annotations

from calibrax.core.executor import LocalExecutor
from calibrax.plugins.hookspecs import hookimpl


@hookimpl
def calibrax_executors() -> list[type]:
    return [LocalExecutor]
