"""Feature extractors on curves with known answers, and their bookkeeping."""

import math

import numpy as np
import pytest

from calibrax.core.data.experiment import Experiment
from calibrax.core.data.features import (FEATURES, curve_shape, experiment_features, feature_def, result_features,
                                    step_suffix, summarise)
from calibrax.core.sheartest import Provenance, ShearTestResult, StepRecord

SIGMA = 8000.0
WINDOW = 0.01


def test_a_linear_start_has_zero_curvature_and_its_slope():
    rot = np.linspace(0.0, 0.2, 401)
    tau = np.where(rot < 0.1, 40000.0 * rot, 4000.0 - 10000.0 * (rot - 0.1))
    shape = curve_shape(rot, tau, SIGMA, WINDOW)
    assert shape.curvature == pytest.approx(0.0, abs=0.02)
    assert shape.initial_slope == pytest.approx(40000.0 / SIGMA, rel=1e-6)
    assert not shape.still_rising


def test_a_concave_start_has_negative_curvature():
    rot = np.linspace(0.0, 0.2, 401)
    u = np.clip(rot / 0.1, 0, 1)
    tau = np.where(rot < 0.1, 4000.0 * (2 * u - u**2), 4000.0)
    tau[rot > 0.12] = 3500.0
    shape = curve_shape(rot, tau, SIGMA, 0.002)
    # y = 2u − u² has c = −1
    assert shape.curvature == pytest.approx(-1.0, abs=0.1)


def test_a_known_peak_and_plateau_give_the_known_prominence_softening_and_position():
    rot = np.linspace(0.0, 0.2, 2001)
    rise = 4000.0 * rot / 0.05
    fall = 4000.0 - 20000.0 * (rot - 0.05)
    tau = np.where(rot < 0.05, rise, np.maximum(fall, 3000.0))
    shape = curve_shape(rot, tau, SIGMA, 0.001)
    assert shape.peak_rotation == pytest.approx(0.05, abs=0.002)
    assert shape.peak_tau == pytest.approx(4000.0, rel=0.01)
    # the plateau (3000 Pa) fills the last quarter: prominence (4000 − 3000)/8000
    assert shape.peak_prominence == pytest.approx(1000.0 / SIGMA, rel=0.02)
    assert shape.end_ratio_tau == pytest.approx(3000.0)
    assert shape.softening < 0


def test_a_curve_still_rising_at_the_window_end_is_flagged_not_given_a_peak():
    rot = np.linspace(0.0, 0.2, 401)
    tau = 1000.0 + 20000.0 * rot
    shape = curve_shape(rot, tau, SIGMA, WINDOW)
    assert shape.still_rising
    for value in (shape.curvature, shape.peak_rotation, shape.peak_prominence, shape.softening):
        assert math.isnan(value)
    assert shape.initial_slope == pytest.approx(20000.0 / SIGMA, rel=1e-6)


def test_names_suffixes_and_definitions():
    assert step_suffix(9000.0) == "9kPa" and step_suffix(7500.0) == "7.5kPa"
    assert feature_def("peak_ratio_7.5kPa").unit == "1"
    assert feature_def("bulk_density").unit == "kg/m³"
    for f in FEATURES.values():
        assert f.unit and len(f.doc) > 20


def _step(kind, sigma, tau_of_rot, n=200, span=0.12):
    rot = np.linspace(span / n, span, n)
    tau = tau_of_rot(rot)
    return StepRecord(kind, sigma, np.linspace(0.01, 0.02, n), rot, tau, np.full(n, sigma), np.full(n, 0.01))


def _result():
    steps, peaks = [], []
    for sigma in (9000.0, 8000.0, 7000.0, 6000.0):
        steps.append(_step("preshear", 15000.0, lambda r: np.full(r.size, 9000.0)))
        peak = 500.0 + 0.5 * sigma
        steps.append(_step("shear", sigma, lambda r, p=peak: np.where(r < 0.06, p * r / 0.06, p - 0.1 * p)))
        peaks.append(peak)
    prov = Provenance("test-double", "0", "h", 0, 1.0, 100)
    n = 4
    return ShearTestResult(tuple(steps), np.asarray(peaks), np.asarray([9000.0, 8000.0, 7000.0, 6000.0]) * 1.02,
                           np.asarray([9000.0, 8000.0, 7000.0, 6000.0]), np.full(n, 0.5), np.full(n, 1450.0),
                           np.full(n, 9000.0), np.full(n, 15000.0), np.full(n, 1e-3), prov)


def test_result_features_read_the_locus_ratios_and_density():
    f = result_features(_result(), 0.005)
    assert f["cohesion"] == pytest.approx(500.0) and f["aif"] == pytest.approx(math.degrees(math.atan(0.5)))
    assert f["peak_ratio_9kPa"] == pytest.approx(5000.0 / 9180.0)
    assert f["preshear_ratio_6kPa"] == pytest.approx(0.6)
    assert f["shear_end_ratio_9kPa"] == pytest.approx(0.9 * 5000.0 / 9000.0)
    assert f["bulk_density"] == 1450.0
    assert f["still_rising_8kPa"] == 0.0
    assert f["cohesion_measured"] < f["cohesion"] + 1  # fitted against the larger measured σ


def test_experiment_features_per_replicate_and_their_spread():
    sig = np.asarray([9000.0, 6000.0] * 3)
    tau = np.asarray([5000.0, 3500.0, 5200.0, 3600.0, 4800.0, 3400.0])
    rep = np.repeat([1, 2, 3], 2)
    exp = Experiment("e", sig, tau, rep, bulk_density=np.asarray([1400, 1400, 1420, 1420, np.nan, np.nan]),
                     measured_normal_stress=sig * 1.1)
    per = experiment_features(exp)
    assert sorted(per) == [1, 2, 3]
    assert per[1]["peak_ratio_9kPa"] == pytest.approx(5000.0 / 9900.0)
    assert per[2]["bulk_density"] == 1420.0 and "bulk_density" not in per[3]
    summary = summarise(per.values())
    assert summary["peak_tau_9kPa"].mean == pytest.approx(5000.0)
    assert summary["peak_tau_9kPa"].sd == pytest.approx(200.0)
    assert summary["bulk_density"].n == 2
    assert "cohesion_measured" in per[1]
