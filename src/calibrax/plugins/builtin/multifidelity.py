"""Builtin multi-fidelity acquisitions: where to simulate next *and at which fidelity*.

Both work on a :class:`~calibrax.core.search.multifidelity.MultiFidelityKriging` model and return
points with their fidelity level as one more column, shape (q, d + 1). ``fidelities`` are the
campaign's (level, cost) pairs, cheapest first, the target last.

* ``mfei`` (the default): the augmented expected improvement of Huang, Allen, Notz and Miller
  (2006, *Struct. Multidisc. Optim.* 32:369, "Sequential kriging optimization using
  multiple-fidelity evaluations"), made for noisy responses: the expected improvement of the
  *target's* posterior mean over the incumbent (the best posterior mean at the evaluated points,
  as ``qei`` takes it), times the posterior correlation between the target and level l at x (how
  much a level-l run tells about the target there), times 1 − σ_ε/√(s_l² + σ_ε²) (a run where the
  model is already as sure as the noise allows teaches nothing), times cost_target / cost_l.
  Points of one batch are chosen one by one, each conditioned on the previous ones (and on the
  pending ones) at their posterior mean (the Kriging believer). It costs a few posterior
  evaluations on a Sobol cloud: well under a second beside a Kriging fit.
* ``mfkg``: BoTorch's multi-fidelity knowledge gradient with inverse-cost weighting (the value of
  a run to the target's best posterior mean, per CPU-second), optimised over the parameters at
  each discrete level with ``optimize_acqf_mixed``. Sound, and one to two orders of magnitude
  slower per proposal (a minute on 2 cores with 14 points): ``benchmarks/multifidelity.py``
  measures both.
"""

from __future__ import annotations

import warnings
from typing import Sequence

import numpy as np

from calibrax.core.search.acquisition import Observations
from calibrax.core.search.answer import grid
from calibrax.core.search.parameters import ParameterSpace
from calibrax.core.options import Option
from calibrax.errors import ConfigError

#: Sobol candidates per level on which ``mfei`` is maximised (then refined locally)
CANDIDATES = 1024


def _expected_improvement(best: float, mean: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """EI of a minimisation below ``best`` (shape of ``mean``)."""
    from scipy.stats import norm

    sd = np.maximum(sd, 1e-12)
    z = (best - mean) / sd
    return (best - mean) * norm.cdf(z) + sd * norm.pdf(z)


class AugmentedExpectedImprovement:
    """``mfei``: Huang et al.'s augmented EI across fidelities (see the module's doc)."""

    name = "mfei"
    needs_model = True
    multi_fidelity = True
    OPTIONS = {"candidates": Option(int, low=16)}

    def __init__(self, candidates: int = CANDIDATES) -> None:
        self.candidates = candidates

    def score(self, model, x: np.ndarray, level: float, cost: float, target_cost: float,
              best: float) -> np.ndarray:
        """AEI at ``x`` shape (m, d) run at ``level`` costing ``cost`` → (m,); ``model`` a
        :class:`~calibrax.core.search.multifidelity.MultiFidelityKriging` or
        :class:`~calibrax.core.search.multifidelity.MultiFidelityComposite`."""
        mean1, sd1 = model.latent(x)
        ei = _expected_improvement(best, mean1, sd1)
        return ei * model.correlation(x, level) * (1.0 - model.noise_share(x, level)) * (target_cost / cost)

    def propose(self, model, space: ParameterSpace, observations: Observations, q: int, *,
                pending: np.ndarray | None = None, seed: int = 0,
                fidelities: Sequence[tuple[float, float]] = ()) -> np.ndarray:
        """``q`` points with their level, shape (q, d + 1)."""
        if model is None or not fidelities:
            raise ConfigError("acquisition", f"{self.name} needs a multi-fidelity model and the campaign's fidelities")
        d = space.dim
        cloud = grid(d, self.candidates, seed=seed)
        local = grid(d, 256, seed=seed + 1)[:256] - 0.5
        target_cost = fidelities[-1][1]
        chosen: list[np.ndarray] = []
        current = model if pending is None or len(pending) == 0 else model.condition(pending)
        for _ in range(q):
            best = -current.best_posterior_mean()
            options = []
            for level, cost in fidelities:
                cand = np.vstack([cloud, current.train_x.numpy()])
                values = self.score(current, cand, level, cost, target_cost, best)
                x, v = cand[int(np.argmax(values))], float(values.max())
                for width in (0.1, 0.01):
                    around = np.clip(x + width * local, 0.0, 1.0)
                    vals = self.score(current, around, level, cost, target_cost, best)
                    if float(vals.max()) > v:
                        x, v = around[int(np.argmax(vals))], float(vals.max())
                options.append((v, level, x))
            _, level, x = max(options, key=lambda t: t[0])
            row = np.append(x, level)
            chosen.append(row)
            current = current.condition(row.reshape(1, -1))
        return np.stack(chosen)


class MultiFidelityKnowledgeGradient:
    """``mfkg``: BoTorch's qMultiFidelityKnowledgeGradient per CPU-second (see the module's doc)."""

    name = "mfkg"
    needs_model = True
    multi_fidelity = True
    OPTIONS = {"num_fantasies": Option(int, low=1), "num_restarts": Option(int, low=1),
               "raw_samples": Option(int, low=1)}

    def __init__(self, num_fantasies: int = 32, num_restarts: int = 4, raw_samples: int = 128) -> None:
        self.num_fantasies, self.num_restarts, self.raw_samples = num_fantasies, num_restarts, raw_samples

    def propose(self, model, space: ParameterSpace, observations: Observations, q: int, *,
                pending: np.ndarray | None = None, seed: int = 0,
                fidelities: Sequence[tuple[float, float]] = ()) -> np.ndarray:
        import torch
        from botorch.acquisition import PosteriorMean, qMultiFidelityKnowledgeGradient
        from botorch.acquisition.cost_aware import InverseCostWeightedUtility
        from botorch.acquisition.fixed_feature import FixedFeatureAcquisitionFunction
        from botorch.acquisition.utils import project_to_target_fidelity
        from botorch.models.deterministic import GenericDeterministicModel
        from botorch.optim import optimize_acqf, optimize_acqf_mixed

        from calibrax.core.search.surrogate import DTYPE

        if model is None or not fidelities:
            raise ConfigError("acquisition", f"{self.name} needs a multi-fidelity model and the campaign's fidelities")
        d = space.dim
        torch.manual_seed(seed)
        levels = np.asarray([lv for lv, _ in fidelities])
        costs = np.asarray([c for _, c in fidelities])

        def cost_of(x: torch.Tensor) -> torch.Tensor:  # costs interpolated in log between the levels
            s = x[..., -1:].detach().numpy()
            return torch.as_tensor(np.exp(np.interp(s, levels, np.log(costs))), dtype=DTYPE)

        bounds = torch.stack([torch.zeros(d + 1, dtype=DTYPE), torch.ones(d + 1, dtype=DTYPE)])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            current = FixedFeatureAcquisitionFunction(PosteriorMean(model.model), d=d + 1, columns=[d], values=[1.0])
            _, value = optimize_acqf(current, bounds=bounds[:, :d], q=1, num_restarts=self.num_restarts,
                                     raw_samples=self.raw_samples, options={"seed": seed})
            kg = qMultiFidelityKnowledgeGradient(
                model.model, num_fantasies=self.num_fantasies, current_value=value.detach(),
                cost_aware_utility=InverseCostWeightedUtility(cost_model=GenericDeterministicModel(cost_of)),
                project=lambda x: project_to_target_fidelity(X=x, target_fidelities={d: 1.0}, d=d + 1),
                X_pending=None if pending is None or len(pending) == 0 else torch.as_tensor(pending, dtype=DTYPE))
            cand, _ = optimize_acqf_mixed(kg, bounds=bounds, q=q, num_restarts=self.num_restarts,
                                          raw_samples=self.raw_samples,
                                          fixed_features_list=[{d: float(lv)} for lv in levels],
                                          options={"seed": seed})
        return cand.detach().numpy().reshape(q, d + 1)


__all__ = ["AugmentedExpectedImprovement", "MultiFidelityKnowledgeGradient"]
