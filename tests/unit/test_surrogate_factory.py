"""The surrogates behind one interface and one factory (calibrax.core.search.models): every
choice of the surrogate options, with one fidelity or several, has builders, and the model each
builds is a :class:`Surrogate`; the composite model falls back to the distance model when the
metrics state no terms."""

from __future__ import annotations

import numpy as np
import pytest

from calibrax.core.config import SURROGATE_CHOICES
from calibrax.core.search.metric import MetricValue
from calibrax.core.search.models import BUILDERS, Surrogate
from calibrax.core.search.points import fit_distance_model
from calibrax.core.search.records import PointRecord, SimulationRecord


def _points(n: int, with_terms: bool, multi_fidelity: bool) -> list[PointRecord]:
    rng = np.random.default_rng(3)
    out = []
    for i in range(n):
        u = rng.random(2)
        features = {"noise_threshold": 0.3}
        if with_terms:
            features.update({"a_sim": u[0], "a_exp": 0.4, "a_scale": 0.1, "b_sim": u[1], "b_exp": 0.4, "b_scale": 0.2})
        metric = MetricValue(float(np.sum((u - 0.4) ** 2) * 5), 0.1, features)
        out.append(PointRecord(i, 1, u, u, ["x", "y"], "sobol", [SimulationRecord(0, i, "done")], metric,
                               ("tiny" if i % 2 else "quick") if multi_fidelity else ""))
    return out


def test_every_surrogate_option_has_builders():
    assert set(BUILDERS) == {(model, multi) for model in SURROGATE_CHOICES["model"] for multi in (False, True)}


@pytest.mark.parametrize("multi_fidelity", [False, True])
@pytest.mark.parametrize("with_terms", [False, True])
def test_the_factory_builds_the_model_the_options_ask_for(with_terms, multi_fidelity):
    levels = {"tiny": 0.0, "quick": 1.0} if multi_fidelity else None
    model = fit_distance_model(_points(8, with_terms, multi_fidelity), {"model": "composite"}, 0, levels=levels)
    expected = {(False, False): "Kriging", (True, False): "CompositeKriging",
                (False, True): "MultiFidelityKriging", (True, True): "MultiFidelityComposite"}
    assert type(model).__name__ == expected[with_terms, multi_fidelity]
    assert isinstance(model, Surrogate)
    distance = fit_distance_model(_points(8, with_terms, multi_fidelity), {"model": "distance"}, 0, levels=levels)
    assert type(distance).__name__ == ("MultiFidelityKriging" if multi_fidelity else "Kriging")
