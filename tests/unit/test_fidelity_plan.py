"""The campaign's fidelity plan (calibrax.core.fidelities): what one fidelity and several answer
for the questions the campaign asks of them, without a campaign or a store."""

from __future__ import annotations

import numpy as np

from calibrax.core.fidelities import Fidelity, MultiFidelity, SingleFidelity, fidelity_plan
from calibrax.core.search.design import sobol_points
from calibrax.core.search.records import PointRecord


def _point(fidelity: str = "", unit=(0.25, 0.75)) -> PointRecord:
    return PointRecord(0, 0, np.asarray(unit), np.asarray(unit), ["a", "b"], "qei", [], fidelity=fidelity)


#: stand-ins for the cells (the plan hands them back, it never reads them)
TINY, QUICK, ONE = object(), object(), object()
FIDS = (Fidelity("tiny", TINY, 70.0, 0.0, 4), Fidelity("quick", QUICK, 250.0, 1.0, 2))


class _Acquisition:
    """Records its call; proposes (x, level) rows with a fidelities argument, x rows without."""

    def __init__(self):
        self.calls = []

    def propose(self, model, space, obs, q, *, pending=None, seed=0, **kw):
        self.calls.append((pending, seed, kw))
        x = np.full((q, 2), 0.5)
        return np.hstack([x, [[0.1], [0.9]][:q]]) if "fidelities" in kw else x


def test_a_config_without_fidelities_plans_one():
    assert isinstance(fidelity_plan((), ONE), SingleFidelity)
    assert isinstance(fidelity_plan(FIDS, QUICK), MultiFidelity)


def test_one_fidelity():
    plan = SingleFidelity(ONE)
    assert plan.levels is None and plan.model_name == "Kriging"
    assert plan.initial_points(5) == 5
    enq = np.asarray([[0.1, 0.2]])
    rows, names = plan.initial_design(enq, 2, 3, seed=7)
    assert names is None and np.array_equal(rows, np.vstack([enq, sobol_points(2, 3, seed=7)]))
    rows, _ = plan.initial_design(np.zeros((0, 2)), 2, 3, seed=7)
    assert np.array_equal(rows, sobol_points(2, 3, seed=7))
    assert plan.at_target(2) is None and plan.at_cheapest(2) is None
    assert plan.pending_rows([]) is None
    assert np.array_equal(plan.pending_rows([_point()]), [[0.25, 0.75]])
    acq = _Acquisition()
    unit, names = plan.propose(acq, None, None, None, 2, None, 11)
    assert unit.shape == (2, 2) and names is None and acq.calls == [(None, 11, {})]
    assert plan.is_target(_point()) and plan.spec(_point()) is ONE
    assert plan.progress({"": [10.0, 1.0]}, ", about 2 min left") == ", about 2 min left"


def test_several_fidelities():
    plan = MultiFidelity(FIDS)
    assert plan.levels == {"tiny": 0.0, "quick": 1.0} and plan.model_name == "multi-fidelity Kriging"
    assert plan.initial_points(99) == 6
    enq = np.asarray([[0.1, 0.2]])
    rows, names = plan.initial_design(enq, 2, 99, seed=7)
    design = sobol_points(2, 4, seed=7)
    # nested: the target's initial points are the first of the cheap level's; enqueued ones at the target
    assert np.array_equal(rows, np.vstack([enq, design, design[:2]]))
    assert names == ["quick"] + ["tiny"] * 4 + ["quick"] * 2
    assert plan.at_target(2) == ["quick", "quick"] and plan.at_cheapest(1) == ["tiny"]
    assert np.array_equal(plan.pending_rows([_point("tiny"), _point("quick")]), [[0.25, 0.75, 0.0], [0.25, 0.75, 1.0]])
    acq = _Acquisition()
    unit, names = plan.propose(acq, None, None, None, 2, None, 11)
    assert unit.shape == (2, 2) and names == ["tiny", "quick"]
    assert acq.calls[0][2] == {"fidelities": [(0.0, 70.0), (1.0, 250.0)]}
    assert plan.nearest(0.4).name == "tiny" and plan.nearest(0.6).name == "quick"
    assert plan.is_target(_point("quick")) and not plan.is_target(_point("tiny")) and not plan.is_target(_point())
    assert plan.spec(_point("tiny")) is TINY and plan.spec(_point("quick")) is QUICK and plan.spec(_point()) is QUICK
    # which fidelity the rest runs at is the search's: CPU per fidelity, cheapest first, no time left
    assert plan.progress({"quick": [600.0, 2.0], "tiny": [45.0, 3.0]}, ", about 2 min left") == \
        "; CPU tiny 45 s (3 sims), quick 10 min (2 sims)"
