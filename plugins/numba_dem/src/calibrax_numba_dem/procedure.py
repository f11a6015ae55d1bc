"""The FT4 shear test on numba_dem: core's stage interpreter
(:class:`~calibrax.core.sheartest.stage_runner.StageRunner`, the test as the stages of
:func:`~calibrax.core.sheartest.procedure_stages.shear_test_stages`) over
:class:`~calibrax_numba_dem.shear_engine.NumbaShearEngine`."""

from __future__ import annotations

import logging
import time

from calibrax.core.sheartest import ShearCellSpec
from calibrax.core.sheartest.engine_control import RunLog
from calibrax.core.sheartest.stage_runner import StageRunner

from .engine import DEMSystem
from .shear_engine import SHEAR_SPEED_LIMIT, NumbaShearEngine

__all__ = ["RunLog", "ShearTestDriver", "SHEAR_SPEED_LIMIT", "new_logger"]


class ShearTestDriver(StageRunner):
    """Runs one :class:`ShearCellSpec` (already validated) on a fresh :class:`NumbaShearEngine`."""

    def __init__(self, spec: ShearCellSpec, log: RunLog):
        super().__init__(spec, NumbaShearEngine(spec), log)

    @property
    def sys(self) -> DEMSystem:
        """The engine's current state (a :class:`~calibrax.core.sheartest.procedure_stages.Fork`
        replaces it)."""
        return self.engine.sys


def new_logger(path) -> logging.Logger:
    """A logger writing to ``path`` only (no propagation to the root logger)."""
    logger = logging.getLogger(f"calibrax_numba_dem.run.{id(path)}.{time.time_ns()}")
    logger.setLevel(logging.INFO)
    logger.propagate = False
    handler = logging.FileHandler(path, mode="w", encoding="utf-8")
    handler.setFormatter(logging.Formatter("%(message)s"))
    logger.addHandler(handler)
    return logger
