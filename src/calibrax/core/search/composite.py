"""The composite Kriging model: one GP per feature of the distance, the distance from their joint
prediction (BoTorch's composite objective).

A distance such as the ``robust`` metric's, d = √Σ ((f_i − f_exp,i)/s_i)², folds smooth features
(peak τ/σ, bulk density … each nearly linear over the box) into a cone with its tip at the
experiment, and adds one seed's noise to each feature before folding. A GP of d must learn the
cone's tip from a handful of noisy points; a GP per feature only learns a smooth surface, with the
feature's own seed noise as its noise (``X_sim_stderr`` from the metric, as a log-normal prior the
way :class:`~calibrax.core.search.surrogate.Kriging` uses it). The distance is then computed from the
features' posterior:

* the **expected distance** m_D(x) = √E[D²] = √Σ ((μ_i − f_exp,i)² + σ_i²)/s_i², with μ_i, σ_i the
  posterior mean and s.d. of feature i's mean at x. It is what the answer minimises (the
  recommendation) and what the surrogate map shows; the σ_i² term keeps the recommendation where
  the features are known, not where an unexplored mean happens to pass the target;
* its s.d. by the delta method, sd(D²)/(2 m_D) with Var D² = Σ (2σ_i⁴ + 4σ_i²(μ_i − f_exp,i)²)/s_i⁴,
  used for the plausible region (m_D − 2 sd ≤ T, as for the distance model);
* the acquisition (qEI, q = 2, or any of the MC acquisitions) samples the features jointly from the
  :class:`~botorch.models.ModelListGP` and scores each sample's −D through a
  :class:`~botorch.acquisition.objective.GenericMCObjective`.

Failed simulations have no features, but a crash is data: the points whose every simulation
failed physically, with the finished ones, give a model of the probability p(x) that the engine
fails at x (:mod:`calibrax.core.search.failures`), and :data:`FAILURE_PENALTY` × the largest
observed distance × (2p(x) − 1, clipped to [0, 1]) is added to the expected distance and to every
sample the acquisition scores. The search and the recommendation keep away from a region that crashes, not only from its
crashed points (the distance model gives such a point a penalty distance instead).

Measured on benchmarks/calibration.py (docs/explanation/answer.md, "How many simulations, measured").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from calibrax.core.search.failures import FailureModel
from calibrax.core.search.surrogate import DTYPE, Kriging

#: the penalty where the engine surely fails, in units of the largest observed distance
FAILURE_PENALTY = 2.0


@dataclass
class CompositeKriging:
    """Per-feature :class:`Kriging` models and the experiment's targets and scales.

    Attributes:
        names: the features, in the order of the model list's outputs.
        features: {name: Kriging} (each a GP of −value, ``identity`` transform).
        target: {name: the experiment's value} (feature units).
        scale: {name: the scale the distance divides by} (feature units).
        train_x: the evaluated points, shape (n, d), unit cube.
        train_y: −(observed distance), shape (n, 1) (the incumbent for ``best_f: observed``).
        failed_x: points whose simulations all failed physically, shape (k, d), unit cube.
        penalty: the failure penalty's height (distance units).
        failure: the model of where the engine fails (None: no point failed).
    """

    names: tuple[str, ...]
    features: dict[str, Kriging]
    target: dict[str, float]
    scale: dict[str, float]
    train_x: torch.Tensor
    train_y: torch.Tensor
    failed_x: torch.Tensor
    penalty: float
    transform: str = "identity"
    failure: FailureModel | None = None

    @classmethod
    def fit(cls, x: np.ndarray, terms: list[dict], distance: np.ndarray, seed: int = 0,
            failed_x: np.ndarray | None = None, fit_feature=None) -> "CompositeKriging":
        """Fit on unit-cube points ``x`` shape (n, d), their metric terms (one
        {name: :class:`~calibrax.core.search.metric.DistanceTerm`} per point) and observed distances (n,).
        The target and scale of each feature are the last point's (they depend on the experiment
        and the seeds per point only). ``failed_x`` shape (k, d): points that failed physically.
        ``fit_feature(values (n,), noise_sd)``: fits one feature's model (default: a
        :class:`Kriging` over ``x``)."""
        if fit_feature is None:
            def fit_feature(values: np.ndarray, noise_sd: float | None) -> Kriging:
                return Kriging.fit(x, values, seed=seed, transform="identity", noise_sd=noise_sd)
        names = tuple(sorted(set.intersection(*(set(t) for t in terms))))
        if not names:
            raise ValueError("the points share no distance term")
        x = np.asarray(x, dtype=float)
        models, target, scale = {}, {}, {}
        for name in names:
            values = np.array([t[name].sim for t in terms], dtype=float)
            noise = np.array([t[name].sim_stderr for t in terms], dtype=float)
            noise = noise[np.isfinite(noise) & (noise > 0)]
            models[name] = fit_feature(values, float(np.median(noise)) if noise.size else None)
            target[name], scale[name] = terms[-1][name].exp, terms[-1][name].scale
        dist = np.asarray(distance, dtype=float)
        ty = -torch.as_tensor(dist, dtype=DTYPE).reshape(-1, 1)
        failed = np.zeros((0, x.shape[1])) if failed_x is None or len(failed_x) == 0 else np.atleast_2d(failed_x)
        penalty = FAILURE_PENALTY * max(float(np.max(dist)), 1.0)
        return cls(names, models, target, scale, torch.as_tensor(x, dtype=DTYPE), ty,
                   torch.as_tensor(failed, dtype=DTYPE), penalty, failure=FailureModel.fit(x, failed, seed))

    def failure_penalty(self, x: torch.Tensor) -> torch.Tensor:
        """The penalty for failing at ``x`` shape (..., d) → (...) (distance units): the height
        times the weight of :meth:`FailureModel.weight` there."""
        if self.failure is None:
            return torch.zeros(x.shape[:-1], dtype=x.dtype)
        return self.penalty * self.failure.weight(x)

    # -- the distance's posterior -------------------------------------------------------------
    def _moments(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """E[D²] and Var[D²] at ``x`` shape (m, d) → two (m,) arrays (features independent)."""
        mean2, var2 = 0.0, 0.0
        for name in self.names:
            mu, sd = self.features[name].latent(x)
            off, s2, c2 = mu - self.target[name], sd**2, self.scale[name] ** 2
            mean2 = mean2 + (off**2 + s2) / c2
            var2 = var2 + (2 * s2**2 + 4 * s2 * off**2) / c2**2
        return np.asarray(mean2, float), np.asarray(var2, float)

    def latent(self, x: np.ndarray, observation_noise: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Expected distance √E[D²] and its delta-method s.d. at ``x`` shape (m, d) → two (m,)
        arrays (distance units; ``observation_noise`` is accepted for the interface and ignored)."""
        xs = np.atleast_2d(np.asarray(x, dtype=float))
        mean2, var2 = self._moments(xs)
        m = np.sqrt(np.maximum(mean2, 0.0))
        sd = np.sqrt(var2) / (2.0 * np.maximum(m, 1e-12))
        if self.failure is not None:
            m = m + self.penalty * self.failure.weight_at(xs)
        return m, sd

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The same as :meth:`latent` (the composite model has no transform)."""
        return self.latent(x)

    def to_model_units(self, distance: float) -> float:
        return float(distance)

    def best_posterior_mean(self) -> float:
        """−(the lowest expected distance at the evaluated points): the incumbent in the
        objective's units (BoTorch maximises −D)."""
        mean, _ = self.latent(self.train_x.numpy())
        return -float(mean.min())

    # -- what the BoTorch acquisitions need ---------------------------------------------------
    @property
    def model(self):
        """The features' :class:`~botorch.models.ModelListGP` (outputs: −feature, in :attr:`names` order)."""
        from botorch.models import ModelListGP

        return ModelListGP(*(self.features[n].model for n in self.names))

    @property
    def objective(self):
        """−D of each joint sample of the features, less the failure penalty at the sample's point (a
        BoTorch ``GenericMCObjective``)."""
        from botorch.acquisition.objective import GenericMCObjective

        target = torch.tensor([self.target[n] for n in self.names], dtype=DTYPE)
        scale = torch.tensor([self.scale[n] for n in self.names], dtype=DTYPE)

        def negative_distance(samples: torch.Tensor, X: torch.Tensor | None = None) -> torch.Tensor:
            d = ((((-samples) - target) / scale) ** 2).sum(-1).sqrt()
            return -(d + self.failure_penalty(X)) if X is not None and self.failed_x.shape[0] else -d

        return GenericMCObjective(negative_distance)

    def hyperparameters(self) -> dict[str, object]:
        """Per feature: length scales, output scale, noise (standardised units); for the store and log."""
        per = {n: self.features[n].hyperparameters() for n in self.names}
        return {"kernel": "composite_matern52_ard", "features": per,
                "lengthscales": [float(np.mean([per[n]["lengthscales"][j] for n in self.names]))
                                 for j in range(self.train_x.shape[-1])],
                "noise": float(np.mean([per[n]["noise"] or 0.0 for n in self.names])),
                "failed_points": int(self.failed_x.shape[0]),
                "n_train": int(self.train_x.shape[0])}


def composite_ready(terms: list[dict]) -> bool:
    """Whether every point states at least one shared, finite distance term with a positive scale."""
    if not terms or any(not t for t in terms):
        return False
    shared = set.intersection(*(set(t) for t in terms))
    return bool(shared) and all(math.isfinite(t[n].sim) and t[n].scale > 0 for t in terms for n in shared)
