"""Where the engine fails: the probability that a simulation at a point fails physically, learnt
from the points that did and did not (a Kriging model of the failure indicator, 1 for a point whose
every simulation failed, 0 for a finished one).

A crash is data. Penalising only a small neighbourhood of each crash keeps the search from
repeating it, but not from trying the rest of a failing region point after point (the region where
a stiff, slippery material blows up is a half of the box, not a point). The indicator's model
carries what the crashes say about their surroundings as far as the finished points let it: near
a finished point the probability is 0, in a region of crashes it is 1, between them it falls
smoothly, the way a feasibility model weights the acquisition in constrained Bayesian optimisation
(Gelbart, Snoek and Adams 2014, with a regression GP of the indicator in place of a classifier).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from calibrax.core.search.surrogate import DTYPE, Kriging

#: the indicator's noise s.d. given to the model: small, so that it interpolates its 0s and 1s
FAILURE_NOISE = 0.05


@dataclass
class FailureModel:
    """A fitted model of the failure indicator over the unit cube.

    Attributes:
        kriging: the :class:`Kriging` model of the indicator (it models −indicator, as a distance).
    """

    kriging: Kriging

    @classmethod
    def fit(cls, done_x: np.ndarray, failed_x: np.ndarray, seed: int = 0) -> "FailureModel | None":
        """Fit on finished points ``done_x`` shape (n, d) and physically failed points ``failed_x``
        shape (k, d), unit cube; None without a failed point."""
        failed_x = np.atleast_2d(np.asarray(failed_x, dtype=float))
        if failed_x.size == 0:
            return None
        done_x = np.asarray(done_x, dtype=float).reshape(-1, failed_x.shape[1])
        x = np.concatenate([done_x, failed_x])
        indicator = np.concatenate([np.zeros(done_x.shape[0]), np.ones(failed_x.shape[0])])
        return cls(Kriging.fit(x, indicator, seed=seed, transform="identity", noise_sd=FAILURE_NOISE))

    def weight(self, x: torch.Tensor) -> torch.Tensor:
        """The penalty's weight at ``x`` shape (..., d) → (...), differentiable in ``x`` (for the
        acquisition); see :func:`penalty_weight`."""
        x = torch.as_tensor(x, dtype=DTYPE)
        return penalty_weight(-self.kriging.model.posterior(x).mean.squeeze(-1))

    def weight_at(self, x: np.ndarray) -> np.ndarray:
        """:meth:`weight` at ``x`` shape (m, d) → (m,), in chunks that never build a joint
        covariance (for maps and the answer)."""
        return penalty_weight(self.kriging.latent(x)[0])


def penalty_weight(indicator_mean):
    """The penalty's weight from the indicator's posterior mean (a numpy array or a torch tensor,
    any shape): with p the mean clipped to [0, 1], 2p − 1 clipped to [0, 1]. It is 0 where a failure
    is no more likely than not and 1 where it is certain, so one crash among finished points repels
    from its own neighbourhood only, while a region of crashes is penalised as a whole."""
    return (2.0 * indicator_mean.clip(0.0, 1.0) - 1.0).clip(0.0, 1.0)


__all__ = ["FAILURE_NOISE", "FailureModel", "penalty_weight"]
