"""Builtin executors: ``local`` (a process per simulation on this machine) and ``dask``."""

from __future__ import annotations

from calibrax.core.running.dask_executor import DaskExecutor
from calibrax.core.running.executor import LocalExecutor
from calibrax.core.hookspecs import hookimpl


@hookimpl
def calibrax_executors() -> list[type]:
    return [LocalExecutor, DaskExecutor]
