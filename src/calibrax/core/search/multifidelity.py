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
            transform: str = "log1p", threshold: float = math.nan) -> "MultiFidelityKriging":
        """Fit on ``x`` shape (n, d), ``level`` shape (n,) in [0, 1] and ``distance`` shape (n,),
        with the noise prior of the metric's threshold (NaN: fitted freely)."""
        xs = with_level(x, level)
        inner = Kriging.fit(xs, distance, seed=seed, transform=transform,
                            noise_sd=noise_sd_from_threshold(threshold), fidelity_column=xs.shape[1] - 1)
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


__all__ = ["MultiFidelityKriging", "TARGET_LEVEL", "with_level"]
