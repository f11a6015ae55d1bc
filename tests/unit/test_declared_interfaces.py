"""A plugin written from the declared interfaces alone (tests/doubles/thirdparty_plugin.py, a test
double registered through CALIBRAX_PLUGINS) is used by the crosscheck's micro level and by the
composite Kriging model: no naming convention, no signature filtering, no attribute probing."""

from __future__ import annotations

import math

from calibrax.core.search.composite import CompositeKriging
from calibrax.core.config import load_config
from calibrax.core.studies.crosscheck import known_differences, micro_agreement, micro_checks
from calibrax.core.search.metric import TermsMetric
from calibrax.core.registry import get_manager
from calibrax.core.search.points import fit_distance_model
from calibrax.core.running.store import CampaignStore
from calibrax.core.sheartest.verification import MICRO_CASES, Verification
from tests.conftest import write_double_campaign
from tests.doubles.thirdparty_plugin import AnalyticDoubleVerification, PeakRatioTermsMetric


def test_the_plugin_implements_the_declared_interfaces_and_is_registered():
    assert isinstance(AnalyticDoubleVerification(), Verification)
    assert isinstance(PeakRatioTermsMetric(), TermsMetric)
    manager = get_manager()
    assert manager.plugins("verification")["analytic_double"].cls is AnalyticDoubleVerification
    assert manager.plugins("metric")["double_terms"].cls is PeakRatioTermsMetric
    assert set(manager.plugins("verification")) >= {"analytic_double"}


def test_the_crosscheck_runs_its_micro_cases_through_the_interface(tmp_path):
    config = load_config(write_double_campaign(tmp_path))
    checks = micro_checks(config, ["analytic_double"])
    # every case but the cohesive pull-off, which a backend without cohesion does not offer
    assert set(checks) == {case for case, (method, _) in MICRO_CASES.items() if method != "cohesive_pull_off"}
    elastic, damped = checks["collision e=1"]["analytic_double"], checks["collision e=material"]["analytic_double"]
    assert elastic["restitution"] == 1.0 and damped["restitution"] == config.spec.material.restitution
    assert math.isfinite(elastic["contact_time"]) and elastic["contact_time"] > 0
    known = known_differences(["analytic_double"])
    assert known["analytic_double"] == {("rolling_resistance", "torque"): AnalyticDoubleVerification.known_differences[
        ("rolling_resistance", "torque")]}
    assert micro_agreement(checks, known) == []  # one backend: nothing to set side by side


def test_the_composite_model_fits_the_terms_the_metric_states(tmp_path):
    path = write_double_campaign(tmp_path, metric="double_terms", surrogate={"model": "composite"},
                                 budget={"initial": 4, "iterations": 0}, executor={"name": "local", "workers": 2})
    config = load_config(path)  # a TermsMetric is accepted for the composite model
    from calibrax.core.studies.campaign import run_campaign

    run_campaign(config)
    points = CampaignStore(config.store).points()
    assert len(points) == 4 and all(p.metric is not None for p in points)
    # the double's pseudo-experiment (write_double_experiment) records no preshear τ: the peak term only
    assert set(points[0].metric.terms()) == {"peak"} == set(PeakRatioTermsMetric().term_names(config.experiment))
    model = fit_distance_model(points, config.surrogate, config.seed)
    assert isinstance(model, CompositeKriging)
    assert list(model.names) == sorted(points[0].metric.terms())
