"""The c_aif metric against a hand computation, and experiment files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calibrax import ShearCellSpec, load_experiment
from calibrax.errors import ConfigError, ExperimentError
from calibrax.plugins.builtin.metrics import CAifMetric
from tests.conftest import write_double_experiment
from tests.doubles.analytic_simulator import AnalyticDoubleSimulator, true_locus


def test_metric_is_zero_at_the_truth_and_scaled_by_the_replicate_spread(tmp_path):
    exp = load_experiment(write_double_experiment(tmp_path / "e.csv", 2e10, 0.45))
    s_c, s_a = exp.spread()
    loci = exp.replicate_loci()
    assert s_c == pytest.approx(np.std([l.cohesion for l in loci], ddof=1))
    sim = AnalyticDoubleSimulator()
    metric = CAifMetric()
    at_truth = metric.evaluate([sim.simulate(ShearCellSpec.preset("tiny", material={"youngs_modulus": 2e10,
                                                                                     "sliding_friction": 0.45}),
                                             tmp_path)], exp)
    off = metric.evaluate([sim.simulate(ShearCellSpec.preset("tiny", material={"youngs_modulus": 2e10,
                                                                                "sliding_friction": 0.6}), tmp_path)],
                          exp)
    assert at_truth.value < 0.3 * off.value
    f = off.features
    by_hand = math.hypot((f["cohesion_sim"] - f["cohesion_exp"]) / s_c, (f["aif_sim"] - f["aif_exp"]) / s_a)
    assert off.value == pytest.approx(by_hand, rel=1e-12)
    assert f["aif_sim"] == pytest.approx(true_locus(2e10, 0.6)[1], abs=0.5)


def test_user_scale_overrides_and_bad_scale_is_refused(tmp_path):
    exp = load_experiment(write_double_experiment(tmp_path / "e.csv"))
    assert CAifMetric(scale_cohesion_pa=100.0, scale_aif_deg=1.0).scales(exp) == (100.0, 1.0)
    from calibrax.core.registry import get_manager

    with pytest.raises(ConfigError, match=r"metric.scale_aif_deg: must be > 0, got -1.0"):
        get_manager().create("metric", "c_aif", scale_aif_deg=-1.0)


def test_metric_uncertainty_propagates_regression_errors(tmp_path):
    from calibrax.core.sheartest import Provenance, ShearTestResult

    exp = load_experiment(write_double_experiment(tmp_path / "e.csv"))
    base = AnalyticDoubleSimulator().simulate(ShearCellSpec.preset("tiny"), tmp_path)
    noisy = ShearTestResult(**{**base.__dict__, "peak_shear_stress": base.peak_shear_stress + [30, -30, 30, -30]})
    v = CAifMetric().evaluate([noisy], exp)
    assert v.uncertainty > 0 and math.isfinite(v.uncertainty)
    assert isinstance(base.provenance, Provenance)


def test_experiment_header_and_curves(tmp_path):
    write_double_experiment(tmp_path / "pts.csv")
    (tmp_path / "curves.csv").write_text("replicate,normal_stress_pa,rotation_rad,shear_stress_pa\n"
                                         "1,9000,0.0,0\n1,9000,0.1,5000\n1,9000,0.05,4000\n")
    (tmp_path / "exp.yaml").write_text("name: B4C\nsource: made by the test double\npoints: pts.csv\n"
                                       "curves: curves.csv\npreshear_stress_pa: 15000\n")
    exp = load_experiment(tmp_path / "exp.yaml")
    assert exp.name == "B4C" and exp.preshear_stress == 15000 and exp.replicates == [1, 2, 3]
    rot, tau = exp.curves[(1, 9000.0)]
    np.testing.assert_array_equal(rot, [0.0, 0.05, 0.1])
    assert "test double" in exp.source


@pytest.mark.parametrize("text, match", [
    ("normal_stress_pa,peak_shear_stress_pa\n9000,1\n", "missing column"),
    ("normal_stress_pa,peak_shear_stress_pa,replicate\n9000,abc,1\n8000,1,1\n", "not a number"),
    ("normal_stress_pa,peak_shear_stress_pa,replicate\n9000,1,1\n9000,2,1\n", "two or more distinct"),
    ("normal_stress_pa,peak_shear_stress_pa,replicate,colour\n9000,1,1,red\n", "unknown column"),
    ("normal_stress_pa,peak_shear_stress_pa,replicate\n9000,inf,1\n8000,1,1\n", "finite"),
])
def test_bad_experiment_files(tmp_path, text, match):
    (tmp_path / "bad.csv").write_text(text)
    with pytest.raises(ExperimentError, match=match):
        load_experiment(tmp_path / "bad.csv")


FULL_POINTS = """# a replicated FT4 shear test with what else the instrument logs
normal_stress_pa,peak_shear_stress_pa,replicate,measured_normal_stress_pa,preshear_normal_stress_pa,preshear_shear_stress_pa,bulk_density_kg_m3
9000,5200,1,9150,15020,8800,1452
6000,3900,1,6080,14990,8700,
9000,5100,2,9110,15010,8650,1440
6000,3850,2,,15000,8600,
"""


def test_what_an_ft4_user_can_also_measure_is_read_and_kept(tmp_path):
    from calibrax.core.running.store import read_experiment_group, write_experiment_group
    import h5py

    (tmp_path / "p.csv").write_text(FULL_POINTS)
    (tmp_path / "c.csv").write_text("replicate,normal_stress_pa,rotation_rad,shear_stress_pa\n"
                                   "1,9000,0.01,2000\n1,9000,0.02,5200\n1,9000,0.03,4800\n")
    (tmp_path / "e.yaml").write_text("name: full\nsource: bench FT4, 2026-11-01\npoints: p.csv\ncurves: c.csv\n"
                                     "wall_friction_angle_deg: 11.5\n"
                                     "material: {sliding_friction: 0.35, youngs_modulus: 2.0e+10}\n")
    exp = load_experiment(tmp_path / "e.yaml")
    assert exp.measured_normal_stress[0] == 9150 and math.isnan(exp.measured_normal_stress[3])
    np.testing.assert_allclose(exp.bulk_density, [1452, 1452, 1440, 1440])  # spread to the replicate's rows
    assert exp.preshear_tau[2] == 8650 and exp.wall_friction_angle_deg == 11.5
    assert (1, 9000.0) in exp.curves
    with h5py.File(tmp_path / "s.h5", "w") as f:
        write_experiment_group(f.create_group("experiment"), exp)
    with h5py.File(tmp_path / "s.h5", "r") as f:
        back = read_experiment_group(f["experiment"])
    np.testing.assert_array_equal(back.bulk_density, exp.bulk_density)
    np.testing.assert_array_equal(back.measured_normal_stress, exp.measured_normal_stress)
    assert back.wall_friction_angle_deg == 11.5
    # the known material (a pseudo-experiment's truth, which the report marks) is kept too
    assert exp.material == back.material == {"sliding_friction": 0.35, "youngs_modulus": 2.0e10}
    # one density for every replicate from the header instead
    (tmp_path / "e2.yaml").write_text("points: p.csv\nbulk_density_kg_m3: 1500\n")
    assert np.all(load_experiment(tmp_path / "e2.yaml").bulk_density == 1500)


@pytest.mark.parametrize("change, message", [
    (lambda t: t.replace("9000,5200,1", "9000,-5200,1"), "peak_shear_stress_pa must be ≥ 0"),
    (lambda t: t.replace(",1452", ",-3"), "bulk_density_kg_m3 must be > 0"),
])
def test_physically_impossible_points_are_refused(tmp_path, change, message):
    (tmp_path / "p.csv").write_text(change(FULL_POINTS))
    with pytest.raises(ExperimentError, match=message):
        load_experiment(tmp_path / "p.csv")


@pytest.mark.parametrize("header, key", [
    ("points: p.csv\nwall_friction_angle_deg: 95\n", "wall_friction_angle_deg"),
    ("points: p.csv\nbulk_density_kg_m3: heavy\n", "bulk_density_kg_m3"),
    ("points: p.csv\nsource: [1, 2]\n", "source"),
    ("points: p.csv\nmaterial: {sliding_friction: low}\n", "material"),
    ("points: p.csv\nmaterial: [0.35]\n", "material"),
])
def test_bad_header_values_name_the_key(tmp_path, header, key):
    (tmp_path / "p.csv").write_text(FULL_POINTS)
    (tmp_path / "e.yaml").write_text(header)
    with pytest.raises(ExperimentError, match=key):
        load_experiment(tmp_path / "e.yaml")


def test_logs_and_status_show_the_features_the_metric_compared():
    """c_aif shows C and AIF; robust its averaged τ/σ and the density (not NaN C and AIF)."""
    from calibrax.core.search.metric import describe_simulated, simulated_features

    assert describe_simulated({"cohesion_sim": 1234.4, "aif_sim": 31.04, "scale_aif": 2.0}) == "C = 1234 Pa, AIF = 31.0°"
    robust = {"peak_ratio_sim": 0.8421, "preshear_ratio_sim": 0.7, "bulk_density_sim": 1480.2, "peak_ratio_exp": 0.9}
    assert describe_simulated(robust) == "peak τ/σ = 0.842, preshear τ/σ = 0.700, ρ = 1480 kg/m³"
    assert [e[0] for e in simulated_features(robust)] == ["peak_ratio_sim", "preshear_ratio_sim", "bulk_density_sim"]
    assert describe_simulated({}) == ""
