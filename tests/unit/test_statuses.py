"""A point's and a simulation's status is a StrEnum: equal to the plain text an older store
holds, and written to the store as plain text (h5py stores no numpy unicode attribute)."""

from __future__ import annotations

import json

import h5py
import numpy as np

from calibrax.core.running.store import CampaignStore
from calibrax.core.search.metric import MetricValue
from calibrax.core.search.records import PointRecord, SimulationRecord, Status


def test_a_status_is_its_text():
    assert Status.DONE == "done" and Status.FAILED == "failed" and Status.PENDING == "pending"
    assert Status("done") is Status.DONE and str(Status.FAILED) == "failed" and f"{Status.PENDING:<8}|" == "pending |"
    assert json.dumps({"s": Status.DONE}) == '{"s": "done"}'
    # records read from an old store, or built with plain text, compare the same way
    sims = [SimulationRecord(0, 1, "failed"), SimulationRecord(1, 2, Status.DONE)]
    point = PointRecord(0, 0, np.zeros(2), np.zeros(2), ["a", "b"], "qei", sims)
    assert point.status is Status.FAILED and point.status == "failed"
    assert PointRecord(0, 0, np.zeros(2), np.zeros(2), ["a", "b"], "qei", sims[:1] + [SimulationRecord(1, 2, "pending")]
                       ).status is Status.PENDING
    sims[0] = SimulationRecord(0, 1, "done")
    assert PointRecord(0, 0, np.zeros(2), np.zeros(2), ["a", "b"], "qei", sims,
                       MetricValue(1.0, 0.1, {})).status is Status.DONE


def test_the_store_writes_plain_text_and_reads_statuses(tmp_path):
    with CampaignStore(tmp_path / "s.h5").acquire() as store:
        store.initialise("hash", {"name": "t"}, "test")
        [pid] = store.add_batch(0, np.zeros((1, 2)), np.zeros((1, 2)), ["a", "b"], [[1, 2]], "qei", None)
        store.add_simulation(pid, 0, 1, None, reason="boom", kind="crash", wall_time=1.0)
    with h5py.File(store.path, "r") as f:
        attr = f[f"points/p{pid:06d}/sim0"].attrs
        assert type(attr["status"]) is str and attr["status"] == "failed"
        assert h5py.check_string_dtype(attr.get_id("status").dtype) is not None
    [point] = store.points()
    assert [s.status for s in point.sims] == [Status.FAILED, Status.PENDING]
    assert all(type(s.status) is Status for s in point.sims) and point.status is Status.PENDING
