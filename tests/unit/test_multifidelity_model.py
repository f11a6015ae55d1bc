"""The multi-fidelity Kriging models and acquisitions on a synthetic two-level function (no
simulator): the cheap level is the target plus a smooth bias, and the model read at the target
must see through it."""

from __future__ import annotations

import numpy as np
import pytest

from calibrax.core.search.multifidelity import MultiFidelityComposite, MultiFidelityKriging
from calibrax.core.search.metric import DistanceTerm
from calibrax.core.search.parameters import Parameter, ParameterSpace
from calibrax.plugins.builtin.multifidelity import AugmentedExpectedImprovement

OPTIMUM = np.array([0.3, 0.6])


def target(x: np.ndarray) -> np.ndarray:
    return 10.0 * np.sum((x - OPTIMUM) ** 2, axis=1)


def cheap(x: np.ndarray) -> np.ndarray:
    """The target with a bias that moves its minimum to (0.3, 0.5)."""
    return 10.0 * ((x[:, 0] - 0.3) ** 2 + (x[:, 1] - 0.5) ** 2)


def _design(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x_cheap = rng.random((16, 2))
    x_target = np.vstack([x_cheap[:4], [[0.35, 0.55], [0.25, 0.65]]])
    return x_cheap, x_target


def test_the_ar1_model_reads_the_target_through_the_cheap_levels_bias():
    x_cheap, x_target = _design()
    x = np.vstack([x_cheap, x_target])
    level = np.r_[np.zeros(len(x_cheap)), np.ones(len(x_target))]
    y = np.r_[cheap(x_cheap), target(x_target)]
    model = MultiFidelityKriging.fit(x, level, y, seed=0, transform="identity", noise_sd=0.01)
    assert model.hyperparameters()["kernel"] == "matern52_ard_ar1_fidelity"
    probe = np.array([[0.3, 0.6], [0.3, 0.5]])
    at_target, _ = model.latent(probe)
    at_cheap, _ = model.latent(probe, level=0.0)
    assert at_target[0] < at_target[1], "the target's minimum is at μ = 0.6, not the cheap level's 0.5"
    assert at_cheap[1] < at_cheap[0]
    assert model.train_x.shape == (len(x), 2)
    assert np.all((model.correlation(probe, 0.0) >= 0) & (model.correlation(probe, 0.0) <= 1))
    np.testing.assert_allclose(model.correlation(probe, 1.0), 1.0)


def test_augmented_ei_returns_points_with_a_level_and_spreads_a_batch():
    x_cheap, x_target = _design(1)
    x = np.vstack([x_cheap, x_target])
    level = np.r_[np.zeros(len(x_cheap)), np.ones(len(x_target))]
    y = np.r_[cheap(x_cheap), target(x_target)]
    model = MultiFidelityKriging.fit(x, level, y, seed=0, transform="identity", noise_sd=0.01)
    space = ParameterSpace((Parameter("a", 0.0, 1.0), Parameter("b", 0.0, 1.0)))
    rows = AugmentedExpectedImprovement(candidates=256).propose(model, space, None, 2, seed=3,
                                                                fidelities=[(0.0, 70.0), (1.0, 250.0)])
    assert rows.shape == (2, 3) and set(rows[:, 2]) <= {0.0, 1.0}
    assert np.all((rows[:, :2] >= 0) & (rows[:, :2] <= 1))
    assert np.max(np.abs(rows[0] - rows[1])) > 1e-3, "the believer moved the second point of the batch"


def test_the_composite_model_carries_the_bias_in_each_feature():
    """Two features, each a line in x whose cheap level is offset: the expected distance at the
    target is smallest where the target's features meet the experiment's."""
    x_cheap, x_target = _design(2)
    x = np.vstack([x_cheap, x_target])
    level = np.r_[np.zeros(len(x_cheap)), np.ones(len(x_target))]

    def features(pts: np.ndarray, offset: float) -> list[dict]:
        return [{"f": DistanceTerm(float(p[0] + offset), OPTIMUM[0], 0.05, sim_stderr=0.01),
                 "g": DistanceTerm(float(p[1] + offset), OPTIMUM[1], 0.05, sim_stderr=0.01)} for p in pts]

    terms = features(x_cheap, -0.1) + features(x_target, 0.0)
    dist = np.array([np.hypot((t["f"].sim - t["f"].exp) / 0.05, (t["g"].sim - t["g"].exp) / 0.05) for t in terms])
    model = MultiFidelityComposite.fit_levels(x, level, terms, dist, seed=0)
    mean, _ = model.latent(np.array([OPTIMUM, OPTIMUM + 0.1]))
    assert mean[0] < mean[1], mean
    assert model.hyperparameters()["kernel"] == "composite_matern52_ard_ar1_fidelity"
    conditioned = model.condition(np.array([[0.5, 0.5, 0.0]]))
    assert conditioned.train_x.shape == (len(x) + 1, 2)


@pytest.mark.parametrize("bad", [{"candidates": 3}, {"candidates": "many"}])
def test_bad_mfei_options_are_refused(bad):
    from calibrax.core.registry import get_manager
    from calibrax.errors import ConfigError

    with pytest.raises(ConfigError, match=r"acquisition.candidates: must be an integer ≥ 16, got"):
        get_manager().create("acquisition", AugmentedExpectedImprovement.name, **bad)
