"""Where the gap lies: the diagnosis's features, read off simulations and an experiment, and each
feature's standardised residual between them.

The diagnosis compares a handful of features that each say something different about the test
(:data:`GROUPS`): the yield locus in friction form (peak τ/σ per step), and the flow and packing
around it (steady τ/σ of the preshears, post-peak τ/σ, bulk density, how stiffly and how clearly
the curves peak). Per-step shape features are averaged over the steps: one seed moves all four
together, and the average is steadier than any one. A feature the experiment lacks (no curves,
no density) is simply left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from calibrax.core.data.features import experiment_features, feature_stress, result_features, step_mean

#: the feature groups: the yield locus (peak τ/σ per step), the packing (bulk density after the
#: preshear, conditioned bulk density), the FT4's compressibility test (how the packing changes
#: from 1 to 15 kPa), steady flow (preshear and post-peak τ/σ) and the curves' shape; the
#: recalibration fits some groups and is judged on the others
GROUPS: dict[str, tuple[str, ...]] = {
    "locus": ("peak_ratio_9kPa", "peak_ratio_8kPa", "peak_ratio_7kPa", "peak_ratio_6kPa"),
    "density": ("bulk_density", "conditioned_bulk_density"),
    "compressibility": ("compressibility",),
    "flow": ("preshear_ratio", "shear_end_ratio"),
    "shape": ("initial_slope", "peak_prominence"),
}
#: the groups the recalibration fits by default: the yield locus and the density, leaving the
#: compressibility test and the τ curves' flow and shape (the reference paper's gap: concave
#: simulated curves without the measured clear peak) to judge it. The compressibility is held out
#: because it is where cohesion shows beside the fitted features: a loose structure that the
#: cohesion holds at 1 kPa collapses by 15 kPa (at `tiny`, Bo 0.6 gave a CPS of 3.6 % against
#: 0.8 ± 0.4 % without), while the flow and shape features move by at most 2.3 noise units at any
#: Bond number (`calibrax sensitivity`), so without it a cohesion's recalibration had nothing
#: held out to be judged on
DEFAULT_FIT = ("locus", "density")


def parse_groups(text: str | tuple[str, ...] | list[str], key: str = "--fit-on") -> tuple[str, ...]:
    """Comma-separated group names, checked: at least one, not all of them."""
    from calibrax.errors import ConfigError

    names = tuple(n.strip() for n in text.split(",") if n.strip()) if isinstance(text, str) else tuple(text)
    bad = [n for n in names if n not in GROUPS]
    if bad or not names or len(set(names)) != len(names):
        raise ConfigError(key, f"comma-separated feature groups from {list(GROUPS)}, each once; got {text!r}")
    if set(names) == set(GROUPS):
        raise ConfigError(key, f"leave at least one group out to judge the recalibration on; got {text!r}")
    return names
#: the per-step stems averaged over the steps (``preshear_ratio`` = mean of ``preshear_ratio_*kPa``)
STEP_MEANS = ("preshear_ratio", "shear_end_ratio", "initial_slope", "peak_prominence", "curvature")


def diagnosis_features(features: dict[str, float]) -> dict[str, float]:
    """The diagnosis's features from one test's :func:`~calibrax.core.data.features.result_features` (or
    one replicate's experiment features): the per-step peak τ/σ as they are, the stems of
    :data:`STEP_MEANS` averaged over the steps, the bulk density, the conditioned bulk density,
    and ``compressibility``: the compressibility at the ramp's highest stress (the FT4's headline
    figure, CPS at 15 kPa for its standard ramp)."""
    out = {k: v for k, v in features.items() if k.startswith("peak_ratio_")}
    for stem in STEP_MEANS:
        value = step_mean(features, stem)
        if math.isfinite(value):
            out[stem] = value
    for name in ("bulk_density", "conditioned_bulk_density"):
        if math.isfinite(features.get(name, math.nan)):
            out[name] = features[name]
    ramp = [(feature_stress(k), v) for k, v in features.items() if k.startswith("compressibility_") and math.isfinite(v)]
    if ramp:
        out["compressibility"] = max(ramp)[1]
    return out


def simulated(results: list, peak_window: float) -> list[dict[str, float]]:
    """The diagnosis's features of each simulated test (one dict per result)."""
    return [diagnosis_features(result_features(r, peak_window)) for r in results]


def measured(experiment, peak_window: float) -> list[dict[str, float]]:
    """The diagnosis's features of each replicate of an experiment."""
    return [diagnosis_features(f) for f in experiment_features(experiment, peak_window).values()]


def usable(names: tuple[str, ...], experiment: list[dict[str, float]], sims: list[dict[str, float]],
           min_share: float = 0.8) -> tuple[str, ...]:
    """The features the experiment has in every replicate and that ``min_share`` of the simulations
    have (a curve still rising at the window's end has no prominence)."""
    out = []
    for n in names:
        if not all(math.isfinite(e.get(n, math.nan)) for e in experiment):
            continue
        have = sum(math.isfinite(s.get(n, math.nan)) for s in sims)
        if sims and have >= min_share * len(sims):
            out.append(n)
    return tuple(out)


@dataclass(frozen=True)
class FeatureGap:
    """One feature's gap between simulation and experiment.

    ``z`` = (sim mean − experiment mean) / √(s_exp²/n_exp + s_sim²/n_sim), where the experiment's
    s.d. is never taken below the simulation's (a real test scatters at least as much as the
    model's seeds; with three replicates its own s.d. can be tiny by chance). ``implausible`` when
    |z| > 3."""

    name: str
    group: str
    experiment_mean: float
    experiment_sd: float
    n_experiment: int
    sim_mean: float
    sim_sd: float
    n_sim: int

    @property
    def stderr(self) -> float:
        """Standard error of the difference of the means, in the feature's unit."""
        s_exp = self.experiment_sd if math.isfinite(self.experiment_sd) else self.sim_sd
        s_exp = max(s_exp, self.sim_sd) if math.isfinite(self.sim_sd) else s_exp
        return math.sqrt(s_exp ** 2 / self.n_experiment + self.sim_sd ** 2 / self.n_sim)

    @property
    def difference(self) -> float:
        return self.sim_mean - self.experiment_mean

    @property
    def z(self) -> float:
        se = self.stderr
        return self.difference / se if se > 0 else math.nan

    @property
    def implausible(self) -> bool:
        from calibrax.diagnosis.scoring import IMPLAUSIBLE_Z

        return abs(self.z) > IMPLAUSIBLE_Z


def group_of(name: str) -> str:
    """The group of a diagnosis feature (``shape`` for one of no group); every step's peak τ/σ is
    the locus, whatever the procedure's stresses (``peak_ratio_1.75kPa`` of the FT4's 3 kPa test)."""
    if name.startswith("peak_ratio_"):
        return "locus"
    return next((g for g, names in GROUPS.items() if name in names), "shape")


def candidate_names(experiment: list[dict[str, float]]) -> tuple[str, ...]:
    """The diagnosis features to look for in an experiment: its steps' peak τ/σ (the paper's four
    when it has none, for a clear "nothing in common" error), highest stress first, and every
    other group's features (:data:`GROUPS`)."""
    steps = {n for replicate in experiment for n in replicate if n.startswith("peak_ratio_") and n.endswith("kPa")}
    locus = tuple(sorted(steps, key=feature_stress, reverse=True)) or GROUPS["locus"]
    return locus + tuple(n for g, names in GROUPS.items() if g != "locus" for n in names)


def feature_gaps(sims: list[dict[str, float]], experiment: list[dict[str, float]], names: tuple[str, ...],
                 seed_sd: dict[str, float] | None = None) -> list[FeatureGap]:
    """Each feature's gap (see :class:`FeatureGap`).

    Args:
        sims: features of each simulation at one point (seeds).
        experiment: features of each replicate.
        names: the features to compare.
        seed_sd: {feature: one simulation's s.d.} from a larger sample (the design's residuals);
            the seeds' own s.d. is used for features it lacks, and where it is larger (a point whose
            bed jams against a rough wall scatters more than the design's average).
    """
    out = []
    for n in names:
        s = np.array([f[n] for f in sims if math.isfinite(f.get(n, math.nan))])
        e = np.array([f[n] for f in experiment if math.isfinite(f.get(n, math.nan))])
        if s.size == 0 or e.size == 0:
            continue
        own = float(np.std(s, ddof=1)) if s.size > 1 else math.nan
        pooled = (seed_sd or {}).get(n, own)
        sd = max(pooled, own) if math.isfinite(own) and math.isfinite(pooled) else pooled
        out.append(FeatureGap(n, group_of(n), float(e.mean()), float(np.std(e, ddof=1)) if e.size > 1 else math.nan,
                              int(e.size), float(s.mean()), float(sd), int(s.size)))
    return out


#: the held-out gap (RMS z over k features) is beyond the noise above this quantile of what seed
#: noise alone gives, √(χ²_k(q) / k) (:func:`noise_gap_limit`): 1.54 for four features
GAP_NOISE_QUANTILE = 0.95


def noise_gap_limit(features: int) -> float:
    """The RMS z over ``features`` features that seed noise alone stays below with probability
    :data:`GAP_NOISE_QUANTILE`: √(χ²_k(q) / k)."""
    from scipy.stats import chi2

    k = max(int(features), 1)
    return math.sqrt(float(chi2.ppf(GAP_NOISE_QUANTILE, k)) / k)


def gap_size(gaps: list[FeatureGap]) -> float:
    """One number for a set of gaps: the root mean square of their z."""
    z = np.array([g.z for g in gaps if math.isfinite(g.z)])
    return float(np.sqrt(np.mean(z ** 2))) if z.size else math.nan
