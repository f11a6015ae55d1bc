"""What a campaign does with a proposal that repeats a point (issue 18, "replicates where they
pay"): a repeat of a finished, pending or just-proposed point runs as a replicate with its own seed;
a repeat of a point that failed physically is replaced, so a crash is never proposed again."""

from __future__ import annotations

import numpy as np

from calibrax.core.search.points import DUPLICATE_TOL, screen_repeats
from calibrax.core.search.metric import MetricValue
from calibrax.core.search.records import PointRecord, SimulationRecord


def _point(pid: int, unit, status: str) -> PointRecord:
    sim = SimulationRecord(0, 1000 + pid, "failed" if status == "failed" else status,
                           kind="simulation_error" if status == "failed" else "")
    metric = MetricValue(1.0, 0.1) if status == "done" else None
    return PointRecord(pid, 0, np.asarray(unit, float), np.asarray(unit, float), ["a", "b"], "sobol", [sim], metric)


POINTS = [_point(0, [0.2, 0.3], "done"), _point(1, [0.7, 0.7], "failed"), _point(2, [0.5, 0.9], "pending")]
SPARE = np.array([[0.7, 0.71], [0.1, 0.95], [0.9, 0.1]])


def test_a_repeat_of_a_finished_or_pending_point_runs_as_a_replicate():
    proposals = np.array([[0.2, 0.3 + DUPLICATE_TOL / 2], [0.5, 0.9]])
    rows, notes = screen_repeats(proposals, POINTS, SPARE)
    assert np.array_equal(rows, proposals)
    assert notes == [("replicate", "proposal repeats point 0"), ("replicate", "proposal repeats point 2")]


def test_two_equal_proposals_in_one_batch_are_two_seeds_at_one_point():
    rows, notes = screen_repeats(np.array([[0.4, 0.4], [0.4, 0.4]]), POINTS, SPARE)
    assert np.array_equal(rows[0], rows[1]) and notes == [("replicate", "proposal repeats another proposal of this batch")]


def test_a_repeat_of_a_failed_point_is_replaced_away_from_every_point():
    rows, notes = screen_repeats(np.array([[0.7, 0.7], [0.3, 0.6]]), POINTS, SPARE)
    assert notes == [("replaced", "proposal repeats a point that failed")]
    assert np.array_equal(rows[0], SPARE[1])  # SPARE[0] lies within 0.05 of the failed point
    assert np.array_equal(rows[1], [0.3, 0.6])
