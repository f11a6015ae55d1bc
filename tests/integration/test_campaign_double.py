"""A whole EGO campaign (Sobol design, Kriging, BoTorch qEI with q = 2) on the analytic TEST DOUBLE
recovers the (E, μs) that made the pseudo-experiment."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calibrax import CampaignStore, load_config, run_campaign
from tests.conftest import TRUE_E, TRUE_MU, calibrax_cli, write_double_campaign


def test_qei_campaign_recovers_known_parameters(tmp_path):
    config = load_config(write_double_campaign(tmp_path, budget={"initial": 6, "iterations": 8}))
    summary = run_campaign(config)
    store = CampaignStore(config.store)
    points = store.points()
    assert len(points) == 6 + 8 * 2 and summary.failed == 0
    batches = [p.batch for p in points]
    for b in range(1, 9):
        assert batches.count(b) == 2, "each EGO iteration proposes q = 2 points"
    assert all(p.acquisition == "qei" for p in points if p.batch > 0)
    models = store.models()
    assert sorted(models) == list(range(1, 9))
    assert all(len(m["lengthscales"]) == 2 for m in models.values())
    best = summary.best_params
    assert abs(math.log10(best["youngs_modulus"]) - math.log10(TRUE_E)) < 0.12, best
    assert abs(best["sliding_friction"] - TRUE_MU) < 0.05, best
    assert summary.best_value < 1.0  # within the experiment's replicate spread
    # The search improves on the initial space-filling design.
    initial_best = min(p.metric.value for p in points if p.batch == 0)
    assert summary.best_value < initial_best
    # The answer (issue 18): the model's recommendation is near the truth and inside its own
    # plausible region, which holds the truth
    answer = summary.answer
    rec = answer["params"]
    assert abs(math.log10(rec["youngs_modulus"]) - math.log10(TRUE_E)) < 0.15, rec
    assert abs(rec["sliding_friction"] - TRUE_MU) < 0.06, rec
    lo, hi = answer["ranges"]["sliding_friction"]
    assert lo <= TRUE_MU <= hi and lo <= rec["sliding_friction"] <= hi, answer["ranges"]


def test_composite_model_campaign_recovers_mu_and_stores_per_feature_models(tmp_path):
    """``surrogate: {model: composite}`` (one GP per distance term, qEI on the distance of their joint
    prediction): every batch proposes q = 2 points, the store keeps each feature's model, and the
    answer is near the truth with the truth inside its plausible region."""
    config = load_config(write_double_campaign(tmp_path, surrogate={"model": "composite"},
                                               budget={"initial": 4, "iterations": 4}))
    summary = run_campaign(config)
    points = CampaignStore(config.store).points()
    assert len(points) == 4 + 4 * 2 and summary.failed == 0
    models = CampaignStore(config.store).models()
    assert sorted(models) == [1, 2, 3, 4]
    assert all(m["kernel"] == "composite_matern52_ard" and set(m["features"]) == {"cohesion", "aif"}
               for m in models.values())
    rec = summary.answer["params"]
    assert abs(rec["sliding_friction"] - TRUE_MU) < 0.08, rec
    lo, hi = summary.answer["ranges"]["sliding_friction"]
    assert lo <= TRUE_MU <= hi


def test_run_twice_resumes_without_repeating(tmp_path):
    path = write_double_campaign(tmp_path, budget={"initial": 4, "iterations": 1})
    first = calibrax_cli("run", str(path))
    assert first.returncode == 0, first.stderr
    store = CampaignStore(tmp_path / "runs/double.h5")
    finished = {p.id: [s.seed for s in p.sims] for p in store.points()}
    stamps = {p.id: store.result(p.id).provenance.wall_time for p in store.points()}
    second = calibrax_cli("run", str(path))
    assert second.returncode == 0, second.stderr
    assert "starts" not in second.stderr  # nothing re-simulated
    assert {p.id: [s.seed for s in p.sims] for p in store.points()} == finished
    assert {p.id: store.result(p.id).provenance.wall_time for p in store.points()} == stamps
    status = calibrax_cli("status", str(tmp_path / "runs/double.h5"))
    assert status.returncode == 0 and "best observed (*" in status.stdout
    # the answer (issue 18): the model's recommendation and plausible region, stored and shown
    assert "answer: " in status.stdout and "Recommended: " in status.stdout and store.answer() is not None


def test_sobol_and_qlogei_and_qnei_run(tmp_path):
    for name in ("sobol", "qlogei", "qnei"):
        folder = tmp_path / name
        folder.mkdir()
        config = load_config(write_double_campaign(folder, acquisition={"name": name, "q": 2},
                                                   budget={"initial": 3, "iterations": 1}))
        summary = run_campaign(config)
        assert summary.points == 5 and summary.done == 5
        pts = CampaignStore(config.store).points()
        assert np.all((np.stack([p.unit for p in pts]) >= 0) & (np.stack([p.unit for p in pts]) <= 1))


def test_enqueued_points_run_first_and_a_resume_runs_new_ones(tmp_path):
    """Hand-chosen points (Ax's and Optuna's enqueue) are simulated first, in batch 0 before the Sobol
    design; points added to ``enqueue`` later run as the next batch when the campaign resumes."""
    first = {"youngs_modulus": 2.0e10, "sliding_friction": 0.35}
    path = write_double_campaign(tmp_path, enqueue=[first], budget={"initial": 3, "iterations": 0})
    run_campaign(load_config(path))
    store = CampaignStore(tmp_path / "runs/double.h5")
    points = store.points()
    assert len(points) == 4 and {p.batch for p in points} == {0}
    assert [p.acquisition for p in points] == ["enqueued"] + ["sobol(initial)"] * 3  # each point its own source
    assert points[0].params() == pytest.approx({k: float(v) for k, v in first.items()}, rel=1e-12)
    later = {"youngs_modulus": 8.0e9, "sliding_friction": 0.6}
    write_double_campaign(tmp_path, enqueue=[first, later], budget={"initial": 3, "iterations": 0})
    summary = run_campaign(load_config(path))
    points = store.points()
    assert summary.points == 5 and points[-1].acquisition == "enqueued" and points[-1].batch == 1
    assert points[-1].params() == pytest.approx({k: float(v) for k, v in later.items()})


def test_warm_start_takes_an_earlier_stores_results_without_simulating_them(tmp_path):
    """A new campaign warm-started from an earlier store (Ax's and Optuna's warm start) begins with
    its finished points, scored by the new campaign's metric, and simulates only its own design
    and iterations; a store of another cell is refused, naming warm_start."""
    from calibrax.errors import ConfigError

    earlier = tmp_path / "earlier"
    earlier.mkdir()
    run_campaign(load_config(write_double_campaign(earlier, budget={"initial": 4, "iterations": 0})))
    old = CampaignStore(earlier / "runs/double.h5")
    later = tmp_path / "later"
    later.mkdir()
    path = write_double_campaign(later, warm_start=str(earlier / "runs/double.h5"),
                                 budget={"initial": 2, "iterations": 1}, metric="robust")
    events = []
    summary = run_campaign(load_config(path), events.append)
    points = CampaignStore(later / "runs/double.h5").points()
    assert summary.points == 4 + 2 + 2
    assert sum(e["event"] == "started" for e in events) == 4  # the earlier four were not simulated again
    warm = [p for p in points if p.acquisition == "warm_start"]
    assert [p.params() for p in warm] == [p.params() for p in old.points()]
    assert all(p.metric is not None and p.metric.features.get("peak_ratio_sim") is not None for p in warm)
    other = tmp_path / "other"
    other.mkdir()
    with pytest.raises(ConfigError) as err:
        load_config(write_double_campaign(other, warm_start=str(earlier / "runs/double.h5"),
                                          cell={"preset": "quick"}))
    assert err.value.key == "warm_start" and "different cell" in str(err.value)
    with pytest.raises(ConfigError) as err:
        load_config(write_double_campaign(other, warm_start="nowhere.h5"))
    assert err.value.key == "warm_start"


def test_patience_stops_a_campaign_whose_answer_has_settled(tmp_path):
    """budget.patience: once the recommendation and the plausible region have stopped moving for
    that many batches, no more points are proposed; the rest of the budget is not spent."""
    events = []
    path = write_double_campaign(tmp_path, budget={"initial": 6, "iterations": 12, "patience": 2})
    summary = run_campaign(load_config(path), events.append)
    stops = [e for e in events if e["event"] == "stopped_early"]
    assert len(stops) == 1 and summary.points < 6 + 12 * 2, summary.points
    answers = [e for e in events if e["event"] == "answer"]
    assert summary.answer is not None and len(answers) >= 3
