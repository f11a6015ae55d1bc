"""Kriging across fidelities, read at the target: the multi-fidelity campaign's model.

One Gaussian process over (x, s): x the parameters in the unit cube (d columns), s the fidelity
level in [0, 1] (:mod:`calibrax.core.fidelities`; 1 is the target). BoTorch's
``SingleTaskMultiFidelityGP`` gives it a Matérn-5/2 kernel over x times a linear truncated
fidelity kernel: the cheap levels are the target plus a bias that is smooth in x and grows as s
falls, learnt from the nested points (a cheap twin of every target point of the initial design).

:class:`MultiFidelityKriging` presents that model as the single-fidelity
:class:`~calibrax.core.search.surrogate.Kriging` does, at s = 1: the answer (recommendation,
plausible region, noise threshold), the report's maps and ``best_posterior_mean`` all speak of the
target fidelity, whatever the points were simulated at.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from calibrax.core.search.composite import CompositeKriging
from calibrax.core.search.surrogate import Kriging, noise_sd_from_threshold

TARGET_LEVEL = 1.0


def with_level(x: np.ndarray, level: float | np.ndarray) -> np.ndarray:
    """``x`` shape (m, d) with the fidelity level appended as its last column → (m, d + 1)."""
    xs = np.atleast_2d(np.asarray(x, dtype=float))
    col = np.broadcast_to(np.asarray(level, dtype=float), (xs.shape[0],)).reshape(-1, 1)
    return np.hstack([xs, col])


@dataclass
class MultiFidelityKriging:
    """A fitted multi-fidelity model read at the target level (see the module's doc).

    Attributes:
        inner: the :class:`Kriging` over (x, s), shape (n, d + 1) inputs, s last.
        dim: d, the number of calibrated parameters.
    """

    inner: Kriging
    dim: int

    @classmethod
    def fit(cls, x: np.ndarray, level: np.ndarray, distance: np.ndarray, seed: int = 0, *,
            transform: str = "log1p", threshold: float = math.nan,
            noise_sd: float | None = None) -> "MultiFidelityKriging":
        """Fit on ``x`` shape (n, d), ``level`` shape (n,) in [0, 1] and values ``distance`` shape
        (n,), with the noise prior ``noise_sd`` (values' units) or else that of the metric's
        ``threshold`` (NaN: fitted freely)."""
        xs = with_level(x, level)
        inner = Kriging.fit(xs, distance, seed=seed, transform=transform,
                            noise_sd=noise_sd if noise_sd is not None else noise_sd_from_threshold(threshold),
                            fidelity_column=xs.shape[1] - 1)
        return cls(inner, xs.shape[1] - 1)

    # The Kriging interface, at the target level --------------------------------------------------
    @property
    def model(self):
        """The BoTorch model over (x, s) (for the acquisitions)."""
        return self.inner.model

    @property
    def transform(self) -> str:
        return self.inner.transform

    @property
    def train_x(self):
        """The evaluated points' parameters, shape (n, d) (torch), whatever their level."""
        return self.inner.train_x[:, :self.dim]

    @property
    def train_level(self) -> np.ndarray:
        """The evaluated points' fidelity levels, shape (n,)."""
        return self.inner.train_x[:, self.dim].numpy()

    def latent(self, x: np.ndarray, observation_noise: bool = False,
               level: float = TARGET_LEVEL) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and s.d. of the transformed distance at ``x`` shape (m, d) and ``level``."""
        return self.inner.latent(with_level(x, level), observation_noise)

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted distance at the target level and its s.d., two (m,) arrays."""
        return self.inner.predict(with_level(x, TARGET_LEVEL))

    def to_model_units(self, distance: float) -> float:
        return self.inner.to_model_units(distance)

    def best_posterior_mean(self) -> float:
        """The best posterior mean of −transform(d) at the target over the evaluated points."""
        mean, _ = self.latent(self.train_x.numpy())
        return -float(mean.min())

    def hyperparameters(self) -> dict[str, object]:
        return {**self.inner.hyperparameters(), "fidelity_levels": sorted(set(self.train_level.round(6).tolist()))}

    # What a multi-fidelity acquisition asks ------------------------------------------------------
    def correlation(self, x: np.ndarray, level: float) -> np.ndarray:
        """Posterior correlation, in [0, 1], between the target and ``level`` at ``x`` (m, d) → (m,)."""
        if level >= TARGET_LEVEL:
            return np.ones(len(np.atleast_2d(x)))
        _, sd1 = self.latent(x)
        _, sdl = self.latent(x, level=level)
        cov = self.inner.covariance(with_level(x, TARGET_LEVEL), with_level(x, level))
        return np.clip(cov / np.maximum(sd1 * sdl, 1e-12), 0.0, 1.0)

    def noise_share(self, x: np.ndarray, level: float) -> np.ndarray:
        """σ_noise / √(s_l² + σ_noise²) at ``x`` (m, d) and ``level`` → (m,): near 1 where the model
        knows the level as well as one run's noise allows (a run there teaches little)."""
        _, sdl = self.latent(x, level=level)
        noise = self.inner.noise_sd()
        return noise / np.sqrt(sdl**2 + noise**2)

    def condition(self, rows: np.ndarray) -> "MultiFidelityKriging":
        """The model conditioned on ``rows`` (k, d + 1), level last, observed at its own posterior
        mean (the Kriging believer: the next point of a batch goes elsewhere)."""
        import torch

        from calibrax.core.search.surrogate import DTYPE

        inner = self.inner
        x = torch.as_tensor(np.atleast_2d(rows), dtype=DTYPE)
        with torch.no_grad():
            y = inner.model.posterior(x).mean
            fantasy = inner.model.condition_on_observations(x, y)
        return MultiFidelityKriging(Kriging(fantasy, torch.cat([inner.train_x, x]), torch.cat([inner.train_y, y]),
                                            inner.transform, inner.noise_floor), self.dim)


class MultiFidelityComposite(CompositeKriging):
    """The composite model (:mod:`calibrax.core.search.composite`: one GP per feature, the distance
    from their joint prediction) with a :class:`MultiFidelityKriging` per feature, read at the
    target. A cheap cell's bias is smooth in each feature (a denser or looser bed, a lower τ/σ)
    where it is not in the distance, which folds the features into a cone; so the features carry it."""

    @classmethod
    def fit_levels(cls, x: np.ndarray, level: np.ndarray, terms: list[dict], distance: np.ndarray, seed: int = 0,
                   failed_x: np.ndarray | None = None) -> "MultiFidelityComposite":
        """As :meth:`CompositeKriging.fit`, with each point's fidelity ``level`` shape (n,)."""
        def fit_feature(values: np.ndarray, noise_sd: float | None) -> MultiFidelityKriging:
            return MultiFidelityKriging.fit(x, level, values, seed, transform="identity",
                                            noise_sd=math.nan if noise_sd is None else noise_sd)

        return cls.fit(x, terms, distance, seed, failed_x, fit_feature)

    def correlation(self, x: np.ndarray, level: float) -> np.ndarray:
        """The features' mean posterior correlation between the target and ``level`` at ``x``."""
        return np.mean([self.features[n].correlation(x, level) for n in self.names], axis=0)

    def noise_share(self, x: np.ndarray, level: float) -> np.ndarray:
        """The features' mean :meth:`MultiFidelityKriging.noise_share`."""
        return np.mean([self.features[n].noise_share(x, level) for n in self.names], axis=0)

    def condition(self, rows: np.ndarray) -> "MultiFidelityComposite":
        """Every feature's model conditioned on ``rows`` at its posterior mean."""
        import torch

        from calibrax.core.search.surrogate import DTYPE

        new = {n: self.features[n].condition(rows) for n in self.names}
        x = torch.cat([self.train_x, torch.as_tensor(np.atleast_2d(rows)[:, :-1], dtype=DTYPE)])
        return MultiFidelityComposite(self.names, new, self.target, self.scale, x, self.train_y, self.failed_x,
                                      self.penalty, failure=self.failure)

    def hyperparameters(self) -> dict[str, object]:
        out = super().hyperparameters()
        out["kernel"] = "composite_matern52_ard_ar1_fidelity"
        return out


__all__ = ["MultiFidelityComposite", "MultiFidelityKriging", "TARGET_LEVEL", "with_level"]
