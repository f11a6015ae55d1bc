"""Everything a report shows, read once from a campaign store.

Each point's C and AIF are refitted from its stored peaks (all seeds pooled), so the report does
not depend on which metric the campaign used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from calibrax.core.data.experiment import Experiment
from calibrax.core.search.parameters import Parameter, ParameterSpace
from calibrax.core.sheartest import ShearTestResult
from calibrax.core.running.store import CampaignStore
from calibrax.core.search.records import PointRecord, Status
from calibrax.core.sheartest.yieldlocus import YieldLocus
from calibrax.errors import CalibraxError, StoreError


@dataclass
class PointView:
    """One point as the report shows it; C in Pa, AIF in degrees, NaN where unknown."""

    record: PointRecord
    results: list[ShearTestResult]
    cohesion: float = float("nan")
    cohesion_stderr: float = float("nan")
    aif: float = float("nan")
    aif_stderr: float = float("nan")

    @property
    def id(self) -> int:
        return self.record.id

    @property
    def distance(self) -> float:
        return self.record.metric.value if self.record.metric is not None else float("nan")

    @property
    def wall_time(self) -> float:
        return float(sum(s.wall_time for s in self.record.sims if math.isfinite(s.wall_time)))


@dataclass
class CampaignData:
    """A campaign store's content for figures: config, space, experiment, points, models."""

    store: Path
    config: dict
    space: ParameterSpace
    experiment: Experiment | None
    points: list[PointView]
    models: dict[int, dict]

    @property
    def done(self) -> list[PointView]:
        return [p for p in self.points if math.isfinite(p.distance)]

    @property
    def best(self) -> PointView | None:
        return min(self.done, key=lambda p: p.distance, default=None)

    @property
    def noise_threshold(self) -> tuple[float, float]:
        """(threshold, rate): the distance the true parameters stay below at that rate, as the
        campaign's metric stated it (the best point's; NaN where the metric states none, and for
        stores written before metrics stated one)."""
        best = self.best
        if best is None or best.record.metric is None:
            return math.nan, math.nan
        return best.record.metric.threshold, best.record.metric.threshold_rate

    @property
    def failures(self) -> list[tuple[PointView, int, str, str, str]]:
        """(point, sim index, kind, reason, log tail) of every failed simulation."""
        return [(p, s.index, s.kind, s.reason, s.log_tail) for p in self.points for s in p.record.sims
                if s.status == Status.FAILED]


def load_campaign(store_path: str | Path) -> CampaignData:
    """Read a store (no lock needed: reading never changes it)."""
    store = CampaignStore(store_path)
    if not store.path.is_file():
        raise StoreError(f"store {store.path} not found")
    config = store.config()
    space = ParameterSpace(tuple(Parameter(name, float(b["low"]), float(b["high"]), bool(b["log"]))
                                 for name, b in config["parameters"].items()))
    views = []
    for record in store.points():
        results = [store.result(record.id, s.index) for s in record.sims if s.status == Status.DONE]
        view = PointView(record, results)
        if results:
            try:
                locus = YieldLocus.fit(np.concatenate([r.target_normal_stress for r in results]),
                                       np.concatenate([r.peak_shear_stress for r in results]))
                view.cohesion, view.cohesion_stderr = locus.cohesion, locus.cohesion_stderr
                view.aif, view.aif_stderr = locus.aif_deg, locus.aif_stderr_deg
            except CalibraxError:
                pass
        views.append(view)
    return CampaignData(store.path, config, space, store.experiment(), views, store.models())
