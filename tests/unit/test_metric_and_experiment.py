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
    with pytest.raises(ConfigError, match="metric.scale_aif_deg"):
        CAifMetric(scale_aif_deg=-1.0)


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
