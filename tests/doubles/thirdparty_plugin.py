"""TEST DOUBLE — a plugin written the way a third party would, from the declared interfaces alone
(:mod:`calibrax.core.sheartest.verification` and :class:`calibrax.core.search.metric.TermsMetric`), for tests of the
core only. Registered through ``CALIBRAX_PLUGINS`` beside the analytic double (tests/conftest.py):

* ``AnalyticDoubleVerification``: the analytic double's micro cases, answered by the analytic
  references themselves (the double has no contact law of its own);
* ``PeakRatioTermsMetric`` (metric ``double_terms``): the distance over the mean peak and preshear
  τ/σ, stated only as ``distance_terms`` (no feature naming convention), so the composite model can
  use it only through the declared interface.
"""

from __future__ import annotations

import math

import numpy as np

from calibrax import hookimpl
from calibrax.core.sheartest.analytic import hertz_contact_time, rolling_stop, sliding_time
from calibrax.core.data.experiment import Experiment
from calibrax.core.search.metric import DistanceTerm, MetricValue
from calibrax.core.sheartest.verification import MicroMaterial


class AnalyticDoubleVerification:
    """The analytic double's Verification: each case returns its analytic answer."""

    name = "analytic_double"
    known_differences = {("rolling_resistance", "torque"): "the double's own rolling law (a test of the report)"}

    def two_sphere_collision(self, material: MicroMaterial) -> dict[str, float]:
        t = hertz_contact_time(material.radius, material.youngs_modulus, material.poisson_ratio, material.density, 0.5)
        return {"contact_time": t, "restitution": material.restitution}

    def sliding_on_base(self, material: MicroMaterial) -> dict[str, float]:
        return {"sliding_time": sliding_time(0.5, material.friction)}

    def rolling_resistance(self, material: MicroMaterial) -> dict[str, float]:
        _, torque, t_stop = rolling_stop(material.radius, material.density, material.rolling_friction, 30.0)
        return {"torque": torque, "stop_time": t_stop}


class PeakRatioTermsMetric:
    """Metric ``double_terms``: d = √Σ ((sim − exp)/scale)² over the mean peak τ/σ and the mean
    preshear τ/σ, each scaled by a fixed 0.05 (the double's own noise is small)."""

    name = "double_terms"
    SCALE = 0.05

    def evaluate(self, results, experiment: Experiment) -> MetricValue:
        exp = self._experiment(experiment)
        sims = {"peak": [float(np.mean(r.peak_shear_stress / r.target_normal_stress)) for r in results],
                "preshear": [float(np.mean(r.preshear_shear_stress / r.preshear_normal_stress)) for r in results]}
        terms = {k: DistanceTerm(float(np.mean(sims[k])), exp[k], self.SCALE, 0.01) for k in exp}
        d = math.sqrt(sum(((t.sim - t.exp) / t.scale) ** 2 for t in terms.values()))
        return MetricValue(d, 0.1, {}, terms)

    @staticmethod
    def _experiment(experiment: Experiment) -> dict[str, float]:
        out = {"peak": float(np.mean(experiment.peak_shear_stress / experiment.normal_stress))}
        pre = np.asarray(experiment.preshear_shear_stress, dtype=float) / experiment.preshear_stress
        if np.isfinite(pre).any():
            out["preshear"] = float(np.nanmean(pre))
        return out

    def term_names(self, experiment: Experiment) -> list[str]:
        return sorted(self._experiment(experiment))


@hookimpl
def calibrax_verifications() -> list[type]:
    return [AnalyticDoubleVerification]


@hookimpl
def calibrax_metrics() -> list[type]:
    return [PeakRatioTermsMetric]
