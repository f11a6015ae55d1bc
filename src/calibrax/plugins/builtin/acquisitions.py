"""Builtin acquisitions: ``qei`` (the paper's q-point EI), ``qlogei``, ``qnei``, ``qlognei`` and
``sobol``; the multi-fidelity ``mfei`` and ``mfkg`` live in :mod:`calibrax.plugins.builtin.multifidelity`.

All work in the unit cube on the :class:`~calibrax.core.search.surrogate.Kriging` model of −distance,
through BoTorch's Monte-Carlo acquisition functions and ``optimize_acqf``. ``qei`` and ``qlogei``
take their incumbent ``best_f`` from the model's posterior mean at the evaluated points (option
``best_f: posterior_mean``, the default): on noisy DEM the best *observed* distance is a lucky
seed, and improving on it is a chase after noise (``best_f: observed`` is the textbook choice).
"""

from __future__ import annotations

import abc
import logging
import warnings

from typing import TYPE_CHECKING

import numpy as np

from calibrax.core.search.acquisition import Observations
from calibrax.core.search.design import sobol_points
from calibrax.core.hookspecs import hookimpl
from calibrax.core.search.parameters import ParameterSpace
from calibrax.core.options import Option
from calibrax.errors import ConfigError

log = logging.getLogger(__name__)
#: a best qEI at or below this (distance units) is flat: every candidate's improvement underflowed
FLAT_EI = 1e-9

if TYPE_CHECKING:  # torch is imported only when a proposal is made: simulation processes never need it
    import torch

    from calibrax.core.search.surrogate import Kriging


class _BoTorchAcquisition(abc.ABC):
    """Shared optimisation of a BoTorch MC acquisition over the unit cube."""

    name = ""
    needs_model = True
    OPTIONS = {"num_restarts": Option(int, low=1), "raw_samples": Option(int, low=1), "mc_samples": Option(int, low=1)}

    def __init__(self, num_restarts: int = 10, raw_samples: int = 256, mc_samples: int = 256) -> None:
        self.num_restarts, self.raw_samples, self.mc_samples = num_restarts, raw_samples, mc_samples

    @abc.abstractmethod
    def build(self, model: "Kriging", observations: Observations, pending: "torch.Tensor | None", sampler):
        """The BoTorch acquisition function to maximise."""

    def propose(self, model: "Kriging | None", space: ParameterSpace, observations: Observations, q: int, *,
                pending: np.ndarray | None = None, seed: int = 0) -> np.ndarray:
        return self.maximise(model, space, observations, q, pending, seed)[0]

    def maximise(self, model: "Kriging | None", space: ParameterSpace, observations: Observations, q: int,
                 pending: np.ndarray | None, seed: int) -> tuple[np.ndarray, float]:
        """The ``q`` points (shape (q, d), unit cube) that maximise :meth:`build`'s acquisition, and
        its value there."""
        import torch
        from botorch.optim import optimize_acqf
        from botorch.sampling import SobolQMCNormalSampler

        from calibrax.core.search.surrogate import DTYPE

        if model is None:
            raise ConfigError("acquisition", f"{self.name} needs a fitted model")
        torch.manual_seed(seed)
        sampler = SobolQMCNormalSampler(sample_shape=torch.Size([self.mc_samples]), seed=seed)
        x_pending = None if pending is None or len(pending) == 0 else torch.as_tensor(pending, dtype=DTYPE)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # BoTorch's advice to prefer qLogEI: qei is the paper's choice
            acqf = self.build(model, observations, x_pending, sampler)
        bounds = torch.stack([torch.zeros(space.dim, dtype=DTYPE), torch.ones(space.dim, dtype=DTYPE)])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cand, value = optimize_acqf(acqf, bounds=bounds, q=q, num_restarts=self.num_restarts,
                                        raw_samples=self.raw_samples, options={"seed": seed})
        return cand.detach().numpy().reshape(q, space.dim), float(value)


def _objective(model):
    """The model's MC objective (the composite model's −distance of the joint feature samples);
    None for the distance model, whose single output is the objective."""
    return getattr(model, "objective", None)


class _ImprovementAcquisition(_BoTorchAcquisition):
    """An improvement criterion over an incumbent ``best_f``: the best posterior mean at the
    evaluated points (``posterior_mean``, default) or the best observation (``observed``)."""

    BEST_F = ("posterior_mean", "observed")
    OPTIONS = {**_BoTorchAcquisition.OPTIONS, "best_f": Option(str, choices=BEST_F)}

    def __init__(self, best_f: str = "posterior_mean", **options: int) -> None:
        super().__init__(**options)
        self.best_f = best_f

    def incumbent(self, model: "Kriging") -> float:
        return model.best_posterior_mean() if self.best_f == "posterior_mean" else float(model.train_y.max())


class QExpectedImprovement(_ImprovementAcquisition):
    """q-point Expected Improvement (the paper's 2-point EI) over the incumbent ``best_f``.

    Where the model is sure that nothing improves on the incumbent, qEI is zero everywhere to
    machine precision (:data:`FLAT_EI`) and its optimiser returns its random starting points:
    proposals anywhere, into a region that crashes as readily as anywhere else. The batch is then
    chosen by qLogEI, the same criterion on a log scale, which still ranks the candidates (Ament
    et al. 2023, "Unexpected improvements to expected improvement")."""

    name = "qei"

    def build(self, model, observations, pending, sampler):
        from botorch.acquisition import qExpectedImprovement

        return qExpectedImprovement(model.model, best_f=self.incumbent(model), sampler=sampler, X_pending=pending,
                                    objective=_objective(model))

    def propose(self, model, space, observations, q, *, pending=None, seed=0):
        unit, value = self.maximise(model, space, observations, q, pending, seed)
        if value > FLAT_EI:
            return unit
        log.info("qEI is flat (at most %.2g, distance units): the batch is ranked by qLogEI", value)
        ranked = QLogExpectedImprovement(self.best_f, num_restarts=self.num_restarts, raw_samples=self.raw_samples,
                                         mc_samples=self.mc_samples)
        return ranked.propose(model, space, observations, q, pending=pending, seed=seed)


class QLogExpectedImprovement(_ImprovementAcquisition):
    """qLogEI: the same criterion on a log scale, numerically robust when EI is tiny."""

    name = "qlogei"

    def build(self, model, observations, pending, sampler):
        from botorch.acquisition.logei import qLogExpectedImprovement

        return qLogExpectedImprovement(model.model, best_f=self.incumbent(model), sampler=sampler,
                                       X_pending=pending, objective=_objective(model))


class QNoisyExpectedImprovement(_BoTorchAcquisition):
    """qNEI: integrates over the noisy incumbent — the right choice for stochastic DEM."""

    name = "qnei"

    def build(self, model, observations, pending, sampler):
        from botorch.acquisition import qNoisyExpectedImprovement

        return qNoisyExpectedImprovement(model.model, X_baseline=model.train_x, sampler=sampler,
                                         X_pending=pending, prune_baseline=True, objective=_objective(model))


class QLogNoisyExpectedImprovement(_BoTorchAcquisition):
    """qLogNEI: qNEI on a log scale (BoTorch's recommended default for noisy objectives)."""

    name = "qlognei"

    def build(self, model, observations, pending, sampler):
        from botorch.acquisition.logei import qLogNoisyExpectedImprovement

        return qLogNoisyExpectedImprovement(model.model, X_baseline=model.train_x, sampler=sampler,
                                            X_pending=pending, prune_baseline=True, objective=_objective(model))


class SobolAcquisition:
    """Space-filling baseline: the next points of a scrambled Sobol sequence (ignores the model)."""

    name = "sobol"
    needs_model = False
    OPTIONS: dict[str, type] = {}

    def propose(self, model, space: ParameterSpace, observations: Observations, q: int, *,
                pending: np.ndarray | None = None, seed: int = 0) -> np.ndarray:
        return sobol_points(space.dim, q, seed=seed, skip=len(observations.x) + (0 if pending is None else len(pending)))


class RandomAcquisition:
    """Uniform random points (a baseline; ignores the model)."""

    name = "random"
    needs_model = False
    OPTIONS: dict[str, type] = {}

    def propose(self, model, space: ParameterSpace, observations: Observations, q: int, *,
                pending: np.ndarray | None = None, seed: int = 0) -> np.ndarray:
        return np.random.default_rng(seed).random((q, space.dim))


@hookimpl
def calibrax_acquisitions() -> list[type]:
    from calibrax.plugins.builtin.multifidelity import AugmentedExpectedImprovement, MultiFidelityKnowledgeGradient

    return [QExpectedImprovement, QLogExpectedImprovement, QNoisyExpectedImprovement, QLogNoisyExpectedImprovement,
            SobolAcquisition, RandomAcquisition, AugmentedExpectedImprovement, MultiFidelityKnowledgeGradient]
