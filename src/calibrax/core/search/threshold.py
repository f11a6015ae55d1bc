"""What "within the noise" means for a distance: the value that the true parameters stay below at a
stated rate (95 % by default), given how the distance is built.

A metric of the form d² = Σ_i (Δ_i / s_i)², where Δ_i is a simulated-minus-measured feature and s_i
its spread, follows at the true parameters (Gaussian noise, the spreads themselves known exactly)
a χ² law with as many degrees of freedom as features. Two things make the true law wider, and both
are counted here rather than assumed away:

* the spreads are *estimated* (from 3 replicates an s.d. has 2 degrees of freedom), so each term is
  a squared Student t, not a squared normal;
* features built from one regression are correlated (C and AIF of a four-point locus have a
  correlation near −1), which moves weight into fewer, larger terms.

The quantile of that law has no closed form, so it is computed by Monte Carlo with a fixed seed:
the same inputs always give the same threshold, to about 0.5 % (200 000 draws).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["NoiseThreshold", "noise_threshold", "welch_dof", "DEFAULT_RATE"]

#: the share of true-parameter evaluations a threshold is built to contain
DEFAULT_RATE = 0.95
_DRAWS = 200_000


@dataclass(frozen=True)
class NoiseThreshold:
    """A distance below which the true parameters lie at ``rate``; ``how`` says how it was built."""

    value: float
    rate: float
    how: str

    def contains(self, distance: float) -> bool:
        return bool(distance <= self.value)


def welch_dof(parts: list[tuple[float, float]]) -> float:
    """Welch–Satterthwaite degrees of freedom of a variance Σ v_j whose parts v_j have ν_j degrees
    of freedom each, given as [(v_j, ν_j)]; ν = ∞ parts (known exactly) count as exact."""
    total = sum(v for v, _ in parts)
    denom = sum(v * v / nu for v, nu in parts if math.isfinite(nu) and nu > 0 and v > 0)
    if total <= 0:
        return math.inf
    return math.inf if denom == 0 else total * total / denom


def noise_threshold(dof: "list[float] | np.ndarray", correlation: np.ndarray | None = None,
                    factor: float = 1.0, rate: float = DEFAULT_RATE, seed: int = 20261128) -> float:
    """The ``rate`` quantile of √(factor · Σ_i t_i²): t_i = z_i / √(χ²_νi / ν_i) with z ~ N(0, R).

    Args:
        dof: ν_i of each term's spread estimate, shape (k,); ``inf`` for a spread known exactly.
        correlation: R, shape (k, k), the terms' correlation (identity if None).
        factor: a variance factor common to every term (e.g. 1/n_exp + 1/n_sim where the spread
            is one replicate's and the compared values are means).
        rate: the quantile, in (0, 1).
        seed: the Monte Carlo's seed (fixed: the threshold is a property of the inputs).

    Returns:
        The threshold on d (not d²).
    """
    nu = np.asarray(dof, dtype=float)
    if nu.size == 0:
        return math.nan
    corr = None if correlation is None else tuple(map(tuple, np.asarray(correlation, dtype=float).tolist()))
    return _threshold(tuple(nu.tolist()), corr, float(factor), float(rate), int(seed))


@functools.lru_cache(maxsize=256)
def _threshold(dof: tuple[float, ...], correlation: tuple[tuple[float, ...], ...] | None, factor: float,
               rate: float, seed: int) -> float:
    """:func:`noise_threshold` on hashable inputs, cached: a campaign scores every point with the
    same degrees of freedom, and one Monte Carlo takes tens of milliseconds."""
    nu = np.asarray(dof, dtype=float)
    k = nu.size
    if correlation is None and np.all(np.isinf(nu)):
        from scipy import stats  # here, not at import: simulation processes import the metrics too

        return math.sqrt(factor * stats.chi2.ppf(rate, k))
    rng = np.random.default_rng(seed)
    corr = np.eye(k) if correlation is None else np.asarray(correlation, dtype=float)
    # a correlation with |ρ| = 1 is singular: a tiny ridge keeps the Cholesky factor defined
    chol = np.linalg.cholesky(corr + 1e-9 * np.eye(k))
    z = rng.standard_normal((_DRAWS, k)) @ chol.T
    for i in range(k):
        if math.isfinite(nu[i]):
            z[:, i] /= np.sqrt(rng.chisquare(nu[i], _DRAWS) / nu[i])
    d2 = factor * np.sum(z * z, axis=1)
    return float(math.sqrt(np.quantile(d2, rate)))
