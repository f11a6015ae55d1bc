"""Builtin metric ``c_aif``: the reference paper's distance in the (C, AIF) plane."""

from __future__ import annotations

import math

import numpy as np

from calibrax.core.experiment import Experiment
from calibrax.core.metric import MetricValue
from calibrax.core.sheartest import ShearTestResult
from calibrax.core.yieldlocus import YieldLocus
from calibrax.errors import ConfigError
from calibrax.plugins.hookspecs import hookimpl


class CAifMetric:
    """d = √(((C_sim − C_exp)/s_C)² + ((AIF_sim − AIF_exp)/s_AIF)²).

    s_C (Pa) and s_AIF (degrees) are the experiment's replicate spread unless given as options
    ``scale_cohesion_pa`` and ``scale_aif_deg``. The simulated locus pools the peaks of every
    seed at the point (fitted against the target σ, as the paper, or ``against: measured``). The
    uncertainty is the regression errors of C and AIF propagated to d (delta method).
    """

    name = "c_aif"
    OPTIONS = {"scale_cohesion_pa": float, "scale_aif_deg": float, "against": str}

    def __init__(self, scale_cohesion_pa: float | None = None, scale_aif_deg: float | None = None,
                 against: str = "target") -> None:
        for key, v in (("scale_cohesion_pa", scale_cohesion_pa), ("scale_aif_deg", scale_aif_deg)):
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ConfigError(f"metric.{key}", f"must be a finite number > 0, got {v!r}")
        if against not in ("target", "measured"):
            raise ConfigError("metric.against", f"must be 'target' or 'measured', got {against!r}")
        self.scale_cohesion_pa = scale_cohesion_pa
        self.scale_aif_deg = scale_aif_deg
        self.against = against

    def scales(self, experiment: Experiment) -> tuple[float, float]:
        """(s_C in Pa, s_AIF in degrees)."""
        s_c, s_a = experiment.spread()
        s_c = self.scale_cohesion_pa or s_c
        s_a = self.scale_aif_deg or s_a
        for key, v in (("scale_cohesion_pa", s_c), ("scale_aif_deg", s_a)):
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"metric.{key}", "the experiment has no replicate spread to scale by; "
                                  "give the scale as a metric option")
        return s_c, s_a

    def evaluate(self, results: list[ShearTestResult], experiment: Experiment) -> MetricValue:
        sigma = np.concatenate([r.target_normal_stress if self.against == "target" else r.peak_normal_stress
                                for r in results])
        tau = np.concatenate([r.peak_shear_stress for r in results])
        sim = YieldLocus.fit(sigma, tau)
        exp = experiment.locus()
        s_c, s_a = self.scales(experiment)
        dc = (sim.cohesion - exp.cohesion) / s_c
        da = (sim.aif_deg - exp.aif_deg) / s_a
        d = math.hypot(dc, da)
        ec, ea = sim.cohesion_stderr / s_c, sim.aif_stderr_deg / s_a
        if d > 1e-12:
            unc = math.sqrt((dc * ec) ** 2 + (da * ea) ** 2) / d
        else:
            unc = math.sqrt((ec**2 + ea**2) / 2.0)
        features = {
            "cohesion_sim": sim.cohesion, "aif_sim": sim.aif_deg,
            "cohesion_sim_stderr": sim.cohesion_stderr, "aif_sim_stderr": sim.aif_stderr_deg,
            "cohesion_exp": exp.cohesion, "aif_exp": exp.aif_deg,
            "scale_cohesion": s_c, "scale_aif": s_a,
        }
        return MetricValue(d, unc, features)


@hookimpl
def calibrax_metrics() -> list[type]:
    return [CAifMetric]
