"""The composite Kriging model (issue 18) on synthetic features with a known answer, through the
real GPs and BoTorch's qEI: its expected distance matches a Monte-Carlo estimate, the answer finds
the features' crossing of the experiment, reports a parameter the features ignore as not
constrained, and qEI over the composite objective proposes points in the cube near the valley."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calibrax.core.search.answer import answer_from_model
from calibrax.core.search.composite import CompositeKriging, composite_ready
from calibrax.core.search.metric import DistanceTerm, MetricValue
from calibrax.core.search.parameters import Parameter, ParameterSpace
from calibrax.plugins.builtin.acquisitions import QExpectedImprovement, QLogNoisyExpectedImprovement
from calibrax.core.search.acquisition import Observations

SPACE = ParameterSpace((Parameter("youngs_modulus", 5e9, 5e10, log=True), Parameter("sliding_friction", 0.1, 0.9)))
#: two features linear in μs (u₁), blind to E (u₀); the experiment sits at u₁ = 0.3
SLOPES = {"peak_ratio": 0.6, "bulk_density": -200.0}
TARGET = {"peak_ratio": 0.6 * 0.3, "bulk_density": -200.0 * 0.3}
NOISE = {"peak_ratio": 0.02, "bulk_density": 6.0}
SCALE = {k: v * math.sqrt(1 + 1 / 3) for k, v in NOISE.items()}  # one seed against 3 replicates


def _terms(x: np.ndarray, rng: np.random.Generator) -> tuple[list[dict], np.ndarray]:
    terms, d = [], []
    for row in x:
        t = {k: DistanceTerm(SLOPES[k] * row[1] + NOISE[k] * rng.standard_normal(), TARGET[k], SCALE[k], NOISE[k])
             for k in SLOPES}
        terms.append(t)
        d.append(math.sqrt(sum(((v.sim - v.exp) / v.scale) ** 2 for v in t.values())))
    return terms, np.asarray(d)


def _fit(n: int = 12, seed: int = 0) -> CompositeKriging:
    rng = np.random.default_rng(seed)
    x = rng.random((n, 2))
    terms, d = _terms(x, rng)
    return CompositeKriging.fit(x, terms, d, seed=seed)


def test_metric_values_state_their_terms():
    robust = MetricValue(1.0, 0.1, {"peak_ratio_sim": 0.7, "peak_ratio_exp": 0.6, "peak_ratio_scale": 0.1,
                                    "peak_ratio_sim_stderr": 0.08, "noise_threshold": 2.8})
    assert robust.terms() == {"peak_ratio": DistanceTerm(0.7, 0.6, 0.1, 0.08)}
    c_aif = MetricValue(1.0, 0.1, {"cohesion_sim": 900.0, "cohesion_exp": 800.0, "scale_cohesion": 200.0,
                                   "cohesion_sim_stderr": 150.0, "aif_sim": 30.0, "aif_exp": 31.0, "scale_aif": 2.0})
    assert set(c_aif.terms()) == {"cohesion", "aif"} and c_aif.terms()["aif"].scale == 2.0
    assert composite_ready([c_aif.terms()]) and not composite_ready([{}])


def test_the_expected_distance_is_the_monte_carlo_mean_of_the_joint_prediction():
    model = _fit()
    x = np.array([[0.5, 0.3], [0.2, 0.8], [0.9, 0.05]])
    m, _ = model.latent(x)
    rng = np.random.default_rng(1)
    d2 = 0.0
    for name in model.names:
        mu, sd = model.features[name].latent(x)
        f = mu + sd * rng.standard_normal((20000, len(x)))
        d2 = d2 + ((f - model.target[name]) / model.scale[name]) ** 2
    assert m == pytest.approx(np.sqrt(d2.mean(axis=0)), rel=0.02)


def test_the_answer_locates_the_crossing_and_leaves_the_blind_parameter_open():
    model = _fit(n=16)
    answer = answer_from_model(model, SPACE, 2.8, 0.95, 16)
    assert answer.params["sliding_friction"] == pytest.approx(0.1 + 0.8 * 0.3, abs=0.05)
    assert answer.constrained == {"youngs_modulus": False, "sliding_friction": True}


@pytest.mark.parametrize("acquisition", [QExpectedImprovement, QLogNoisyExpectedImprovement])
def test_qei_over_the_composite_objective_proposes_two_points_near_the_valley(acquisition):
    model = _fit()
    obs = Observations(model.train_x.numpy(), -model.train_y.numpy().ravel(), np.full(12, np.nan))
    batch = acquisition().propose(model, SPACE, obs, 2, seed=3)
    assert batch.shape == (2, 2) and np.all((batch >= 0) & (batch <= 1))
    assert np.all(np.abs(batch[:, 1] - 0.3) < 0.25), batch


def test_a_failed_point_repels_the_recommendation_and_the_search():
    """A crash is data: a point whose simulations all failed, in the valley itself, raises the
    expected distance around it, less and less away from it, not at all at the finished points;
    and neither the answer nor qEI lands there."""
    rng = np.random.default_rng(0)
    x = rng.random((12, 2))
    terms, d = _terms(x, rng)
    crash = np.array([[0.5, 0.3]])
    model = CompositeKriging.fit(x, terms, d, seed=0, failed_x=crash)
    clean = CompositeKriging.fit(x, terms, d, seed=0)
    assert model.latent(crash)[0][0] > clean.latent(crash)[0][0] + model.penalty * 0.9
    away = np.array([[0.5, 0.3 + step] for step in (0.1, 0.2, 0.3)])
    added = model.latent(away)[0] - clean.latent(away)[0]
    assert np.all(np.diff(added) < 0) and added[0] < model.penalty, added
    assert model.latent(x)[0] == pytest.approx(clean.latent(x)[0])
    obs = Observations(x, d, np.full(12, np.nan))
    batch = QExpectedImprovement().propose(model, SPACE, obs, 2, seed=3)
    assert np.all(np.linalg.norm(batch - crash, axis=1) > 0.05), batch
    assert model.hyperparameters()["failed_points"] == 1


def test_a_region_of_crashes_is_penalised_as_a_whole():
    """Five crashes spread over x₀ > 0.6 make an untried point among them nearly as bad as a crash,
    while the finished points in x₀ < 0.6 keep their distance: the search learns the region, not
    five holes in it."""
    rng = np.random.default_rng(1)
    x = rng.random((10, 2)) * np.array([0.55, 1.0])
    terms, d = _terms(x, rng)
    crashes = np.array([[0.7, 0.1], [0.9, 0.3], [0.75, 0.55], [0.95, 0.75], [0.7, 0.95]])
    model = CompositeKriging.fit(x, terms, d, seed=0, failed_x=crashes)
    clean = CompositeKriging.fit(x, terms, d, seed=0)
    inside = np.array([[0.85, 0.45], [0.85, 0.85]])
    assert np.all(model.latent(inside)[0] - clean.latent(inside)[0] > 0.5 * model.penalty)
    assert model.latent(x)[0] == pytest.approx(clean.latent(x)[0])
