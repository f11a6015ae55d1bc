"""Noise thresholds: the Monte Carlo law against closed forms, and each metric's bookkeeping."""

import math

import numpy as np
import pytest
from scipy import stats

from calibrax.core.data.experiment import Experiment
from calibrax.core.search.threshold import noise_threshold, welch_dof
from calibrax.plugins.builtin.metrics import CAifMetric, RobustMetric


def test_known_spreads_give_the_chi_square_quantile():
    assert noise_threshold([math.inf] * 4) == pytest.approx(math.sqrt(stats.chi2.ppf(0.95, 4)))


def test_one_estimated_spread_gives_students_t():
    # one term: t² with ν dof, whose 95 % quantile is F(1, ν) = t_{0.975, ν}²
    assert noise_threshold([3]) == pytest.approx(stats.t.ppf(0.975, 3), rel=0.02)


def test_fully_correlated_terms_act_as_one_larger_term():
    # z1 = z2: d² = 2 z², so d_95 = √2 · 1.96
    corr = np.ones((2, 2))
    assert noise_threshold([math.inf, math.inf], corr) == pytest.approx(math.sqrt(2) * 1.96, rel=0.02)


def test_welch_dof():
    assert welch_dof([(1.0, 4.0), (1.0, 4.0)]) == pytest.approx(8.0)
    assert welch_dof([(1.0, 2.0), (0.0, 2.0)]) == pytest.approx(2.0)
    assert math.isinf(welch_dof([(1.0, math.inf)]))


def _experiment(replicates: int, rng, with_density=True):
    sig = np.tile([9000.0, 8000.0, 7000.0, 6000.0], replicates)
    tau = 500.0 + 0.55 * sig + rng.normal(0, 150.0, sig.size)
    rep = np.repeat(np.arange(1, replicates + 1), 4)
    dens = np.repeat(1450.0 + rng.normal(0, 10.0, replicates), 4) if with_density else None
    return Experiment("e", sig, tau, rep, bulk_density=dens, preshear_sigma=np.full(sig.size, 15000.0),
                      preshear_tau=np.full(sig.size, 9000.0) + rng.normal(0, 200.0, sig.size))


def test_c_aif_threshold_counts_replicates_seeds_and_the_loci_correlation():
    rng = np.random.default_rng(0)
    metric = CAifMetric()
    three, how = metric.threshold(_experiment(3, rng), n_sim=1)
    assert "3 replicates" in how and "correlation -0.99" in how
    # more replicates: a better-known spread and a better-known experimental locus → a tighter threshold
    ten, _ = metric.threshold(_experiment(10, rng), n_sim=1)
    assert ten < three
    # the same spread taken as known exactly, one seed against 3 replicates: d² = (1/3 + 1)(z1² + z2²) with
    # corr(z1, z2) = ρ ≈ −0.99, i.e. about (4/3)(1 + |ρ|) χ²₁
    fixed = CAifMetric(scale_cohesion_pa=100.0, scale_aif_deg=1.0)
    known, _ = fixed.threshold(_experiment(3, rng), n_sim=1)
    rho = 7500.0 / math.sqrt(np.mean(np.asarray([9.0, 8.0, 7.0, 6.0]) ** 2) * 1e6)
    assert known == pytest.approx(math.sqrt(4 / 3 * (1 + rho) * stats.chi2.ppf(0.95, 1)), rel=0.03)


def test_robust_metric_scales_by_the_combined_spread_and_states_its_threshold():
    from calibrax.core.data.features import experiment_features, summarise

    rng = np.random.default_rng(1)
    exp = _experiment(4, rng)
    metric = RobustMetric(seed_spread={"peak_ratio": 0.02, "preshear_ratio": 0.01, "bulk_density": 12.0},
                          seed_spread_seeds=8)
    spread = metric.scales(exp)
    assert set(spread) == {"peak_ratio", "preshear_ratio", "bulk_density"}
    # a simulated result equal to the experiment's means is at d = 0
    from tests.unit.test_features import _result

    res = _result()
    value = metric.evaluate([res], exp)
    summary = summarise(RobustMetric._aggregate(f) for f in experiment_features(exp).values())
    sim_ratio = float(np.mean(res.peak_shear_stress / res.peak_normal_stress))
    scale = math.sqrt(summary["peak_ratio"].sd ** 2 / 4 + 0.02**2)
    assert value.features["peak_ratio_scale"] == pytest.approx(scale)
    assert value.features["peak_ratio_sim"] == pytest.approx(sim_ratio)
    assert (value.features["peak_ratio_sim"] - value.features["peak_ratio_exp"]) / scale == pytest.approx(
        (sim_ratio - summary["peak_ratio"].mean) / scale)
    # three features whose spread is mostly the seeds' (8 seeds): a little above √χ²₃(0.95) = 2.80
    assert 2.8 < value.threshold < 3.6 and value.threshold_rate == 0.95
    # without densities the feature is left out, not invented
    no_density = RobustMetric().scales(_experiment(4, rng, with_density=False))
    assert "bulk_density" not in no_density


def test_robust_metric_refuses_unknown_features():
    from calibrax.errors import ConfigError

    from calibrax.core.registry import get_manager

    def create(**options):
        return get_manager().create("metric", RobustMetric.name, **options)

    with pytest.raises(ConfigError, match=r"metric.features: unknown item\(s\) \['peak_tau'\]; allowed"):
        create(features=["peak_tau"])
    with pytest.raises(ConfigError, match="metric.seed_spread.peak_ratio: must be > 0, got -1.0"):
        create(seed_spread={"peak_ratio": -1.0})
    with pytest.raises(ConfigError, match="metric.seed_spread.peak_tau: unknown key"):
        create(seed_spread={"peak_tau": 1.0})
