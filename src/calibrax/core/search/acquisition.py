"""The Acquisition protocol: where to simulate next, in the unit cube.

Acquisitions work on a fitted :class:`~calibrax.core.search.surrogate.Kriging` surrogate (BoTorch's
separation of model and acquisition); a space-filling one (``sobol``) ignores the model.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from calibrax.core.search.parameters import ParameterSpace


@dataclass(frozen=True)
class Observations:
    """What the search knows: unit-cube points ``x`` shape (n, d), distances ``y`` shape (n,)
    (lower is better) and their 1-σ uncertainties ``y_std`` shape (n,) (NaN where unknown); in a
    multi-fidelity campaign, each point's fidelity ``level`` shape (n,) (1: the target), else None."""

    x: np.ndarray
    y: np.ndarray
    y_std: np.ndarray
    level: np.ndarray | None = None


@runtime_checkable
class Acquisition(Protocol):
    """Proposes ``q`` new points."""

    name: str
    needs_model: bool

    def propose(self, model: object | None, space: ParameterSpace, observations: Observations, q: int, *,
                pending: np.ndarray | None = None, seed: int = 0) -> np.ndarray:
        """Return shape (q, d) points in [0, 1]^d. ``pending``: shape (p, d) points being simulated."""
        ...
