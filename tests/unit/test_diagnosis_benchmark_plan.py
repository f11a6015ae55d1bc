"""Which cases the diagnosis benchmark makes: every class at both levels, the unlisted effect's
truth, and the listed+unlisted cases cycling through every listed effect with the right answer."""

from __future__ import annotations

from collections import Counter

import pytest

from calibrax.diagnosis.benchmark.cases import MAGNITUDES, ROLLING_FRICTION_TRUTH, expected_answer, listed_and_unlisted
from calibrax.diagnosis.benchmark.emulated import plan_emulated
from calibrax.diagnosis.benchmark.model import BenchmarkModel
from calibrax.diagnosis.benchmark.plan import listed_classes, plan_dem


@pytest.fixture(scope="module")
def model() -> BenchmarkModel:
    return BenchmarkModel.load()


def test_listed_and_unlisted_pairs_each_listed_effect_at_medium_with_the_unlisted_one(model) -> None:
    pairs = listed_and_unlisted(listed_classes(model))
    assert [name for name, _ in pairs] == ["wall_friction", "size_distribution", "cohesion"]
    for (name, effects), (_, pname) in zip(pairs, listed_classes(model)):
        assert effects == {pname: MAGNITUDES[pname]["medium"], "rolling_friction": ROLLING_FRICTION_TRUTH}
    assert ROLLING_FRICTION_TRUTH == 0.0 < model.spec.material.rolling_friction


def test_the_dem_plan_has_every_class_and_each_mixed_case_names_its_listed_effect(model) -> None:
    plans = plan_dem(model)
    classes = Counter(p.label.klass for p in plans)
    # three per class on numba_dem, and the wall-friction class again on LIGGGHTS
    assert classes == {"wall_friction": 6, "size_distribution": 3, "cohesion": 3, "none": 3, "unlisted": 3,
                       "listed+unlisted": 3}
    mixed = [p.label for p in plans if p.label.klass == "listed+unlisted"]
    assert sorted(lab.expected for lab in mixed) == ["cohesion", "size_distribution", "wall_friction"]
    params = dict(listed_classes(model))
    for lab in mixed:
        assert lab.effects[params[lab.expected]] == MAGNITUDES[params[lab.expected]]["medium"]
        assert lab.effects["rolling_friction"] == ROLLING_FRICTION_TRUTH
        assert not [p for p in plans if p.label == lab][0].oracle_seeds   # no oracle: two effects
    unlisted = [p.label for p in plans if p.label.klass == "unlisted"]
    assert all(lab.effects == {"rolling_friction": 0.0} and lab.expected == expected_answer("unlisted")
               for lab in unlisted)


def test_the_emulator_plan_cycles_the_mixed_cases_evenly(model) -> None:
    labels = plan_emulated(model, 3, seed=0)
    mixed = Counter(lab.expected for lab in labels if lab.klass == "listed+unlisted")
    assert mixed == {"wall_friction": 2, "size_distribution": 2, "cohesion": 2}
    assert len({lab.case for lab in labels}) == len(labels)


def test_a_mixed_case_without_its_listed_effect_is_refused() -> None:
    with pytest.raises(ValueError, match="listed effect"):
        expected_answer("listed+unlisted")
