"""The Metric protocol: a scalar distance between simulation and experiment, to minimise."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

from calibrax.core.experiment import Experiment
from calibrax.core.sheartest import ShearTestResult


@dataclass(frozen=True)
class MetricValue:
    """A distance (dimensionless unless the metric says otherwise), its 1-σ uncertainty, and the
    named features it was built from (e.g. ``cohesion_sim`` in Pa, ``aif_sim`` in degrees)."""

    value: float
    uncertainty: float
    features: dict[str, float] = field(default_factory=dict)

    @property
    def threshold(self) -> float:
        """The distance the true parameters stay below at :attr:`threshold_rate` (NaN where the metric
        states none): what "within the noise" means for this metric (see calibrax.core.threshold)."""
        return float(self.features.get("noise_threshold", float("nan")))

    @property
    def threshold_rate(self) -> float:
        return float(self.features.get("noise_threshold_rate", float("nan")))

    def within_noise(self) -> bool:
        """Whether the distance lies within the metric's noise threshold."""
        return bool(self.value <= self.threshold)


@runtime_checkable
class Metric(Protocol):
    """Turns the results of one parameter point (one per seed) into a :class:`MetricValue`."""

    name: str

    def evaluate(self, results: list[ShearTestResult], experiment: Experiment) -> MetricValue:
        """Distance of ``results`` (≥ 1 shear tests at the same parameters) to ``experiment``."""
        ...
