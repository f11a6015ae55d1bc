"""A campaign's points and their simulations as plain records: what the store reads back and the
search works on (:mod:`calibrax.core.running.store` writes and reads them; the search needs none of
the store to use them)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from calibrax.core.search.metric import MetricValue


class Status(StrEnum):
    """A simulation's or a point's state. A str: it compares equal to the plain text an older
    store holds, and the store writes ``str(status)`` (h5py stores no enum)."""

    PENDING = "pending"  #: not finished (not run yet, in flight, or interrupted)
    DONE = "done"  #: a simulation: it returned a result; a point: its metric is known
    FAILED = "failed"  #: a simulation: it failed; a point: every simulation finished, no metric


@dataclass
class SimulationRecord:
    """One simulation of a point (one seed)."""

    index: int
    seed: int
    status: Status
    wall_time: float = float("nan")
    reason: str = ""
    log_tail: str = ""
    kind: str = ""
    provenance: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def cpu_seconds(self, threads: int = 1) -> float:
        """Its CPU time (s): the engine's own count where its provenance holds one (numba_dem's
        ``stage_cpu``, every thread's process time), else the wall time × ``threads`` (the
        provenance's where it records them: a failed simulation has none); NaN where it never
        finished. The same rule as :attr:`calibrax.core.sheartest.result.Provenance.cpu_seconds`."""
        stages = (self.provenance.get("extra") or {}).get("stage_cpu")
        if stages:
            return float(sum(stages.values()))
        return float(self.wall_time) * max(int(self.provenance.get("threads", threads)), 1)


@dataclass
class PointRecord:
    """One proposed parameter point and what became of it."""

    id: int
    batch: int
    unit: np.ndarray
    natural: np.ndarray
    names: list[str]
    acquisition: str
    sims: list[SimulationRecord]
    metric: MetricValue | None = None
    #: the fidelity preset it was simulated at, in a multi-fidelity campaign ("": the campaign's cell)
    fidelity: str = ""

    @property
    def status(self) -> Status:
        """Done (metric known), failed (every simulation finished, no metric) or pending."""
        if self.metric is not None:
            return Status.DONE
        if self.sims and all(s.status != Status.PENDING for s in self.sims):
            return Status.FAILED
        return Status.PENDING

    def params(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, self.natural)}
