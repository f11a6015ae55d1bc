"""The campaign's Kriging models behind one interface (:class:`Surrogate`) and one factory
(:func:`fit_surrogate`): the surrogate options' ``model`` and whether the campaign has several
fidelities pick the builders to try, in order (:data:`BUILDERS`); the first that fits is the model.

* ``composite`` (the default): one GP per distance term
  (:class:`~calibrax.core.search.composite.CompositeKriging`), the distance model when the points'
  metrics state no shared terms or fewer than 2 points finished;
* ``distance``: one GP on the distance (:class:`~calibrax.core.search.surrogate.Kriging`), its
  noise prior from the metric's threshold (``noise: metric``) or free (``fitted``);
* with several fidelities, their multi-fidelity versions
  (:mod:`calibrax.core.search.multifidelity`), read at the target.

The models' modules are imported by the builders, when one is fitted: they pull in torch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Protocol, runtime_checkable

import numpy as np

from calibrax.core.search.acquisition import Observations
from calibrax.core.search.records import PointRecord


@runtime_checkable
class Surrogate(Protocol):
    """What the campaign, the answer and the acquisitions read off a fitted model."""

    def latent(self, x: np.ndarray, observation_noise: bool = False) -> tuple[np.ndarray, np.ndarray]: ...

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def to_model_units(self, distance: float) -> float: ...

    def best_posterior_mean(self) -> float: ...

    def hyperparameters(self) -> dict[str, object]: ...


@dataclass(frozen=True)
class TrainingData:
    """What a model is fitted on: the :class:`Observations` (penalised failures included, each
    point's fidelity level with ``levels``), the finished points (a metric known), the points that
    failed physically, the levels ({fidelity name: level}, a multi-fidelity campaign's; else None)
    and the metric's noise threshold."""

    obs: Observations
    finished: list[PointRecord]
    failed: list[PointRecord]
    levels: dict[str, float] | None
    threshold: float


#: a builder: (data, surrogate options, seed) → a fitted model, or None when it cannot fit the data
Builder = Callable[[TrainingData, dict, int], "Surrogate | None"]


def _failed_x(data: TrainingData) -> np.ndarray | None:
    return np.stack([p.unit for p in data.failed]) if data.failed else None


def fit_distance(data: TrainingData, options: dict, seed: int) -> Surrogate:
    """One Kriging model of the distance (penalised failures included)."""
    from calibrax.core.search.surrogate import Kriging, noise_sd_from_threshold

    noise_sd = noise_sd_from_threshold(data.threshold) if options.get("noise", "metric") == "metric" else None
    return Kriging.fit(data.obs.x, data.obs.y, seed=seed, transform=options.get("transform", "log1p"),
                       noise_sd=noise_sd)


def fit_composite(data: TrainingData, options: dict, seed: int) -> Surrogate | None:
    """One Kriging model per distance term, the failed points as penalties; None with fewer than 2
    finished points or when their metrics state no shared terms."""
    from calibrax.core.search.composite import CompositeKriging, composite_ready

    terms = [p.metric.terms() for p in data.finished]
    if len(data.finished) < 2 or not composite_ready(terms):
        return None
    return CompositeKriging.fit(np.stack([p.unit for p in data.finished]), terms,
                                np.asarray([p.metric.value for p in data.finished]), seed=seed,
                                failed_x=_failed_x(data))


def fit_multi_fidelity_distance(data: TrainingData, options: dict, seed: int) -> Surrogate:
    """One multi-fidelity Kriging model of the distance, read at the target."""
    from calibrax.core.search.multifidelity import MultiFidelityKriging

    obs = data.obs
    threshold = data.threshold if options.get("noise", "metric") == "metric" else math.nan
    return MultiFidelityKriging.fit(obs.x, obs.level, obs.y, seed, transform=options.get("transform", "log1p"),
                                    threshold=threshold)


def fit_multi_fidelity_composite(data: TrainingData, options: dict, seed: int) -> Surrogate | None:
    """One multi-fidelity Kriging model per distance term; None as :func:`fit_composite`."""
    from calibrax.core.search.composite import composite_ready
    from calibrax.core.search.multifidelity import MultiFidelityComposite

    terms = [p.metric.terms() for p in data.finished]
    if len(data.finished) < 2 or not composite_ready(terms):
        return None
    return MultiFidelityComposite.fit_levels(
        np.stack([p.unit for p in data.finished]), np.asarray([data.levels[p.fidelity] for p in data.finished]),
        terms, np.asarray([p.metric.value for p in data.finished]), seed, failed_x=_failed_x(data))


#: (surrogate ``model`` option, several fidelities?) → the builders to try, in order
BUILDERS: dict[tuple[str, bool], tuple[Builder, ...]] = {
    ("composite", False): (fit_composite, fit_distance),
    ("distance", False): (fit_distance,),
    ("composite", True): (fit_multi_fidelity_composite, fit_multi_fidelity_distance),
    ("distance", True): (fit_multi_fidelity_distance,),
}


def fit_surrogate(data: TrainingData, options: dict, seed: int) -> Surrogate:
    """The model the surrogate ``options`` ({model, transform, noise}) ask for, fitted on ``data``
    with ``seed``: the first of its :data:`BUILDERS` that fits."""
    kind = "composite" if options.get("model", "composite") == "composite" else "distance"
    for build in BUILDERS[kind, data.obs.level is not None]:
        model = build(data, options, seed)
        if model is not None:
            return model
    raise AssertionError(f"no builder fitted a {kind} model")  # the last builder of each kind always fits


__all__ = ["Surrogate", "TrainingData", "Builder", "BUILDERS", "fit_surrogate", "fit_distance", "fit_composite",
           "fit_multi_fidelity_distance", "fit_multi_fidelity_composite"]
