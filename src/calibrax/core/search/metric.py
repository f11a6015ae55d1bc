"""The Metric protocol: a scalar distance between simulation and experiment, to minimise.

A metric whose distance is d = √Σ ((sim − exp)/scale)² over named features implements
:class:`TermsMetric` as well: it says which terms it compares (:meth:`TermsMetric.term_names`) and
returns them in every value's ``distance_terms`` ({name: :class:`DistanceTerm`}). The composite
Kriging model (one GP per term, the default) needs such a metric; any other metric is modelled by a
GP of its distance.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

from calibrax.core.data.experiment import Experiment
from calibrax.core.sheartest.result import ShearTestResult


#: the simulated features a metric may state, as logs and status show them: (feature key, label,
#: unit, format); a metric shows those of its features that are present (c_aif: C and AIF; robust:
#: the mean peak and preshear τ/σ and the bulk density)
SIMULATED_FEATURES = (("cohesion_sim", "C", "Pa", ".0f"), ("aif_sim", "AIF", "°", ".1f"),
                      ("peak_ratio_sim", "peak τ/σ", "", ".3f"), ("preshear_ratio_sim", "preshear τ/σ", "", ".3f"),
                      ("shear_end_ratio_sim", "end τ/σ", "", ".3f"), ("bulk_density_sim", "ρ", "kg/m³", ".0f"))


def simulated_features(features: dict[str, float]) -> list[tuple[str, str, str, str]]:
    """The entries of :data:`SIMULATED_FEATURES` present in a metric's ``features``."""
    return [entry for entry in SIMULATED_FEATURES if entry[0] in features]


def describe_simulated(features: dict[str, float]) -> str:
    """"C = 1200 Pa, AIF = 31.0°" or "peak τ/σ = 0.842, preshear τ/σ = 0.701, ρ = 1480 kg/m³": the
    simulated features a metric's value was built from."""
    return ", ".join(f"{label} = {format(features[key], fmt)}" + (f" {unit}" if unit and unit != "°" else unit)
                     for key, label, unit, fmt in simulated_features(features))


@dataclass(frozen=True)
class MetricValue:
    """A distance (dimensionless unless the metric says otherwise), its 1-σ uncertainty, and the
    named features it was built from (e.g. ``cohesion_sim`` in Pa, ``aif_sim`` in degrees)."""

    value: float
    uncertainty: float
    features: dict[str, float] = field(default_factory=dict)
    #: the distance's terms, where the metric states them (:class:`TermsMetric`)
    distance_terms: dict[str, "DistanceTerm"] = field(default_factory=dict)

    @property
    def threshold(self) -> float:
        """The distance the true parameters stay below at :attr:`threshold_rate` (NaN where the metric
        states none): what "within the noise" means for this metric (see calibrax.core.search.threshold)."""
        return float(self.features.get("noise_threshold", float("nan")))

    @property
    def threshold_rate(self) -> float:
        return float(self.features.get("noise_threshold_rate", float("nan")))

    def within_noise(self) -> bool:
        """Whether the distance lies within the metric's noise threshold."""
        return bool(self.value <= self.threshold)

    def terms(self) -> dict[str, DistanceTerm]:
        """The distance's terms, {name: :class:`DistanceTerm`}: :attr:`distance_terms`, or for a value
        read back from a store, those its stored features encode (:func:`terms_from_features`).
        Empty when the metric states none (the composite model then cannot be used)."""
        return dict(self.distance_terms) if self.distance_terms else terms_from_features(self.features)


def terms_from_features(features: dict[str, float]) -> dict[str, "DistanceTerm"]:
    """The distance terms a store keeps among a value's features (:func:`terms_as_features`):
    ``X_sim``, ``X_exp`` and ``X_scale`` (or ``scale_X``), with ``X_sim_stderr`` as the simulated
    value's 1-σ noise where given."""
    out = {}
    for key, sim in features.items():
        if not key.endswith("_sim"):
            continue
        name = key[: -len("_sim")]
        exp = features.get(f"{name}_exp")
        scale = features.get(f"{name}_scale", features.get(f"scale_{name}"))
        if exp is None or scale is None:
            continue
        out[name] = DistanceTerm(float(sim), float(exp), float(scale),
                                 float(features.get(f"{name}_sim_stderr", float("nan"))))
    return out


def terms_as_features(terms: dict[str, "DistanceTerm"]) -> dict[str, float]:
    """Distance terms as the flat features a store keeps (the inverse of :func:`terms_from_features`)."""
    out: dict[str, float] = {}
    for name, t in terms.items():
        out.update({f"{name}_sim": t.sim, f"{name}_exp": t.exp, f"{name}_scale": t.scale,
                    f"{name}_sim_stderr": t.sim_stderr})
    return out


@dataclass(frozen=True)
class DistanceTerm:
    """One feature's part of a distance: the simulated value (the point's seeds pooled), the
    experiment's, the scale it is divided by (same units) and the simulated value's 1-σ noise (NaN:
    not stated)."""

    sim: float
    exp: float
    scale: float
    sim_stderr: float = float("nan")


@runtime_checkable
class Metric(Protocol):
    """Turns the results of one parameter point (one per seed) into a :class:`MetricValue`."""

    name: str

    def evaluate(self, results: list[ShearTestResult], experiment: Experiment) -> MetricValue:
        """Distance of ``results`` (≥ 1 shear tests at the same parameters) to ``experiment``."""
        ...


@runtime_checkable
class TermsMetric(Metric, Protocol):
    """A :class:`Metric` whose distance is d = √Σ ((sim − exp)/scale)² over named terms, stated in
    every value's ``distance_terms``; the composite Kriging model needs one."""

    def term_names(self, experiment: Experiment) -> list[str]:
        """The terms the distance compares against ``experiment`` (``["cohesion", "aif"]``)."""
        ...
