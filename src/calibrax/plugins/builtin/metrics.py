"""Builtin metrics: ``c_aif`` (the reference paper's distance in the (C, AIF) plane) and ``robust``
(a distance on the features that rise above a coarse cell's seed noise).

Each states its noise threshold — the distance the true parameters stay below 95 % of the time —
in :attr:`MetricValue.features` (``noise_threshold``, ``noise_threshold_rate``), built by
:mod:`calibrax.core.search.threshold` from how the distance is made; status, logs and reports say
"within the noise" against it, never against d ≤ 1.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from calibrax.core.data.experiment import Experiment
from calibrax.core.data.features import experiment_features, result_features, step_mean, summarise
from calibrax.core.search.metric import MetricValue, terms_from_features
from calibrax.core.sheartest import ShearTestResult
from calibrax.core.search.threshold import DEFAULT_RATE, noise_threshold, welch_dof
from calibrax.core.sheartest.yieldlocus import YieldLocus
from calibrax.core.options import Option
from calibrax.errors import ConfigError
from calibrax.core.hookspecs import hookimpl


def _threshold_features(value: float, rate: float, how: str) -> dict[str, Any]:
    return {"noise_threshold": value, "noise_threshold_rate": rate, "noise_threshold_how": how}


class CAifMetric:
    """d = √(((C_sim − C_exp)/s_C)² + ((AIF_sim − AIF_exp)/s_AIF)²).

    s_C (Pa) and s_AIF (degrees) are the experiment's replicate spread unless given as options
    ``scale_cohesion_pa`` and ``scale_aif_deg``. The simulated locus pools the peaks of every
    seed at the point (fitted against the target σ, as the paper, or ``against: measured``). The
    uncertainty is the regression errors of C and AIF propagated to d (delta method).

    Noise threshold: at the true parameters C_sim − C_exp has the variance s_C² (1/n_exp + 1/n_sim)
    when a seed scatters as much as a replicate (as in a pseudo-experiment); s_C is estimated from
    n_exp replicates (n_exp − 1 degrees of freedom), and C and AIF of one locus are correlated by
    the regression itself, ρ = −mean(σ)/√mean(σ²) (≈ −0.99 over 6–9 kPa). With 3 replicates that
    makes the 95 % threshold about 7: a c_aif distance from three replicates cannot tell much.
    """

    name = "c_aif"
    OPTIONS = {"scale_cohesion_pa": Option(float, low=0.0, low_open=True),
               "scale_aif_deg": Option(float, low=0.0, low_open=True),
               "against": Option(str, choices=("target", "measured"))}

    def __init__(self, scale_cohesion_pa: float | None = None, scale_aif_deg: float | None = None,
                 against: str = "target") -> None:
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

    def threshold(self, experiment: Experiment, n_sim: int, rate: float = DEFAULT_RATE) -> tuple[float, str]:
        """The noise threshold of d for ``n_sim`` pooled seeds, and how it was built."""
        loci = len(experiment.replicate_loci())
        sigma = np.unique(experiment.normal_stress)
        rho = -float(np.mean(sigma) / math.sqrt(np.mean(sigma**2)))
        given = self.scale_cohesion_pa is not None and self.scale_aif_deg is not None
        factor = 1.0 / max(loci, 1) + 1.0 / n_sim
        if given:
            nu, how = math.inf, "scales given as options (taken as one test's noise, known exactly)"
        elif loci >= 2:
            nu, how = loci - 1, f"{loci} replicates ({loci - 1} dof)"
        else:
            nu = max(experiment.normal_stress.size - 2, 1)
            how = f"one replicate: its regression errors ({nu:g} dof) as the spread"
        how += f", {n_sim} seed(s), C–AIF correlation {rho:.2f}"
        value = noise_threshold([nu, nu], np.asarray([[1.0, rho], [rho, 1.0]]), factor=factor, rate=rate)
        return value, how

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
        limit, how = self.threshold(experiment, len(results))
        features = {
            "cohesion_sim": sim.cohesion, "aif_sim": sim.aif_deg,
            "cohesion_sim_stderr": sim.cohesion_stderr, "aif_sim_stderr": sim.aif_stderr_deg,
            "cohesion_exp": exp.cohesion, "aif_exp": exp.aif_deg,
            "scale_cohesion": s_c, "scale_aif": s_a, **_threshold_features(limit, DEFAULT_RATE, how),
        }
        return MetricValue(d, unc, features, terms_from_features(features))

    def term_names(self, experiment: Experiment) -> list[str]:
        """C and AIF (a :class:`~calibrax.core.search.metric.TermsMetric`)."""
        return ["cohesion", "aif"]


class RobustMetric:
    """A distance on features that rise above a coarse cell's seed noise:

        d² = Σ_i ((f_sim,i − f_exp,i) / s_i)²,   s_i² = s_exp,i² / n_exp + s_seed,i² / n_sim,

    over the peak τ/σ_measured averaged over the shear steps (``peak_ratio``), the steady τ/σ of the
    preshears averaged over the test (``preshear_ratio``) and the bulk density at the preshear
    stress (``bulk_density``) where the experiment measured it. f_exp is the replicates' mean, f_sim
    the seeds' mean at the point. Averages over the steps, because the steps' errors are nearly
    independent, some anti-correlated: at ``tiny`` and Table 1 (8 seeds) one step's peak τ/σ has a
    seed s.d. of 0.17–0.24 and the four steps' mean 0.11.

    Options:
        features: the feature stems to use: ``peak_ratio``, ``preshear_ratio``, ``bulk_density`` (the
            default) and ``shear_end_ratio`` (the end-of-window τ/σ, from τ curves); a stem the
            experiment lacks is left out.
        seed_spread: {stem: s.d. of one simulation}, the simulation's seed-to-seed spread (measure it
            with ``benchmarks/seed_noise.py``); without it the experiment's replicate spread stands in,
            which is exact for a pseudo-experiment made by the same cell.
        seed_spread_seeds: how many seeds ``seed_spread`` was measured from (its degrees of freedom
            are one fewer); default: taken as exact.

    Noise threshold: the 95 % quantile of Σ t_i² with each t_i's degrees of freedom from Welch–
    Satterthwaite on s_i² (independent features), by :func:`~calibrax.core.search.threshold.noise_threshold`.
    """

    name = "robust"
    STEMS = ("peak_ratio", "preshear_ratio", "shear_end_ratio", "bulk_density")
    DEFAULT = ("peak_ratio", "preshear_ratio", "bulk_density")
    OPTIONS = {"features": Option(list, choices=STEMS, nonempty=True),
               "seed_spread": Option(dict, choices=STEMS, low=0.0, low_open=True, nonempty=True),
               "seed_spread_seeds": Option(int, low=2)}

    def __init__(self, features: list[str] | None = None, seed_spread: dict[str, float] | None = None,
                 seed_spread_seeds: int | None = None) -> None:
        stems = list(features) if features is not None else list(self.DEFAULT)
        spread = dict(seed_spread or {})
        self.stems = stems
        self.seed_spread = spread
        self.seed_dof = math.inf if seed_spread_seeds is None else seed_spread_seeds - 1

    @staticmethod
    def _aggregate(f: dict[str, float]) -> dict[str, float]:
        """One feature dict's values for the metric: the means over the steps of the peak, preshear
        and end-of-window τ/σ, and the bulk density."""
        out = {}
        for stem in ("peak_ratio", "preshear_ratio", "shear_end_ratio"):
            value = step_mean(f, stem)
            if math.isfinite(value):
                out[stem] = value
        if "bulk_density" in f and math.isfinite(f["bulk_density"]):
            out["bulk_density"] = f["bulk_density"]
        return out

    def _experiment_summary(self, experiment: Experiment) -> dict[str, Any]:
        return self._replicate_summary([self._aggregate(f) for f in experiment_features(experiment).values()])

    def _replicate_summary(self, replicates: list[dict[str, float]]) -> dict[str, Any]:
        return {k: v for k, v in summarise(replicates).items() if k in self.stems}

    def scales(self, experiment: Experiment) -> dict[str, float]:
        """The experiment's replicate spread of each feature used; ConfigError when there is none."""
        summary = self._experiment_summary(experiment)
        if not summary:
            raise ConfigError("metric.features", f"the experiment has none of the features {self.stems}")
        spread = {}
        for name, s in summary.items():
            sd = s.sd if math.isfinite(s.sd) and s.sd > 0 else math.nan
            if not math.isfinite(sd) and name not in self.seed_spread:
                raise ConfigError(f"metric.seed_spread.{name}",
                                  f"the experiment has a single replicate of {name}, so no spread to scale by; "
                                  "give the simulation's seed spread")
            spread[name] = sd
        return spread

    def evaluate(self, results: list[ShearTestResult], experiment: Experiment) -> MetricValue:
        return self.evaluate_features([self._aggregate(result_features(r)) for r in results],
                                      [self._aggregate(f) for f in experiment_features(experiment).values()])

    def evaluate_features(self, sims: list[dict[str, float]], replicates: list[dict[str, float]]) -> MetricValue:
        """The distance from the metric's features directly: ``sims`` one dict per seed and
        ``replicates`` one per experimental replicate, each {stem: value} (``peak_ratio`` …)."""
        exp = self._replicate_summary(replicates)
        sim = summarise(sims)
        n_sim = len(sims)
        total, dofs, feats, seed_var = 0.0, [], {}, {}
        for name, e in exp.items():
            if name not in sim:
                continue
            s_exp = e.sd if e.n > 1 and math.isfinite(e.sd) else 0.0
            given = name in self.seed_spread
            s_seed = self.seed_spread[name] if given else s_exp
            var_exp, var_sim = s_exp**2 / e.n, s_seed**2 / n_sim
            seed_var[name] = var_sim
            nu = welch_dof([(var_exp, max(e.n - 1, 1)), (var_sim, self.seed_dof)]) if given else max(e.n - 1, 1)
            scale = math.sqrt(var_exp + var_sim)
            if not scale > 0:
                raise ConfigError(f"metric.seed_spread.{name}", "neither the experiment's replicates nor the "
                                  "given seed spread say how much this feature scatters; give its seed spread")
            z = (sim[name].mean - e.mean) / scale
            total += z * z
            dofs.append(nu)
            feats[f"{name}_sim"], feats[f"{name}_exp"], feats[f"{name}_scale"] = sim[name].mean, e.mean, scale
            feats[f"{name}_sim_stderr"] = math.sqrt(var_sim)
        if not dofs:
            return MetricValue(math.nan, math.nan, feats, terms_from_features(feats))
        d = math.sqrt(total)
        limit = noise_threshold(dofs)
        how = (f"{len(dofs)} features, seed spread {'given' if self.seed_spread else 'from the replicates'}, "
               f"dof {min(dofs):.3g}–{max(dofs):.3g}")
        # the uncertainty of d from the simulation's own seed noise (delta method: z_i moves by
        # s_seed,i/√n_sim over its scale)
        grad2 = [((feats[f"{n}_sim"] - feats[f"{n}_exp"]) / feats[f"{n}_scale"] ** 2) ** 2 * seed_var[n]
                 for n in seed_var]
        unc = math.sqrt(sum(grad2)) / d if d > 0 else 0.0
        feats.update(_threshold_features(limit, DEFAULT_RATE, how))
        return MetricValue(d, unc, feats, terms_from_features(feats))

    def term_names(self, experiment: Experiment) -> list[str]:
        """The features compared that the experiment has (a :class:`~calibrax.core.search.metric.TermsMetric`)."""
        return sorted(self._experiment_summary(experiment))


@hookimpl
def calibrax_metrics() -> list[type]:
    return [CAifMetric, RobustMetric]
