"""``calibrax status`` on stores written directly (no simulation): units and whole names in the
header, blank cells for what is not known yet, and a pending point told apart as running, queued
or interrupted (issue 21)."""

from __future__ import annotations

import numpy as np

from calibrax.core.studies.simulation_setup import simulation_workdir
from calibrax.core.running.executor import ATTEMPTS_LOG
from calibrax.core.running.store import CampaignStore
from calibrax.report.status import status_text

NAMES = ["youngs_modulus", "sliding_friction"]


def _store(tmp_path) -> CampaignStore:
    """A store with three proposed points, none simulated, whose work folders are under tmp_path."""
    natural = np.array([[1.0e10, 0.3], [2.0e10, 0.5], [3.0e10, 0.7]])
    with CampaignStore(tmp_path / "c.h5").acquire() as store:
        store.initialise("hash", {"workdir": str(tmp_path / "work")}, "test")
        store.add_batch(0, natural * 0, natural, NAMES, [[1], [2], [3]], "sobol(initial)", None)
    return CampaignStore(tmp_path / "c.h5")


def _started(tmp_path, point_id: int, line: str = "2026-01-01T00:00:00Z host=h pid=1 started numba_dem seed=1") -> None:
    folder = simulation_workdir(tmp_path / "work", point_id, 0)
    folder.mkdir(parents=True)
    (folder / ATTEMPTS_LOG).write_text(line + "\n")


def test_header_has_whole_names_and_units_and_pending_cells_are_blank(tmp_path):
    text = status_text(_store(tmp_path))
    header = text.splitlines()[0]
    assert "youngs_modulus [Pa]" in header and "sliding_friction [-]" in header
    rows = text.splitlines()[2:5]
    assert all("nan" not in row for row in rows), rows
    assert all(not row.rstrip().endswith("0.0") for row in rows), rows  # no wall time before any ran


def test_a_stopped_campaigns_pending_points_are_interrupted(tmp_path):
    store = _store(tmp_path)
    _started(tmp_path, 0)
    text = status_text(store)
    assert "3 points: 0 done, 0 failed, 3 interrupted" in text, text
    assert "run again" in text


def test_a_running_campaign_tells_running_from_queued(tmp_path):
    store = _store(tmp_path)
    _started(tmp_path, 0)
    _started(tmp_path, 1, "2026-01-01T00:00:01Z host=h pid=1 failed (crash): died")  # a retry waits
    with CampaignStore(store.path).acquire():
        assert store.in_use()
        text = status_text(store)
    assert not store.in_use()
    states = {int(row.split()[0]): row.split()[5] for row in text.splitlines()[2:5]}
    assert states == {0: "running", 1: "queued", 2: "queued"}, text
    assert "1 running, 2 queued; the campaign is running" in text, text
