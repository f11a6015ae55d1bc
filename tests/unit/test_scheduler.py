"""The scheduler every study runs its simulations through: outcomes, failures as data, starts."""

from __future__ import annotations

import concurrent.futures as cf
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest

from calibrax.core.running.executor import SimulationTask
from calibrax.core.running.scheduler import Scheduler
from calibrax.core.sheartest import ShearCellSpec
from calibrax.errors import FailureKind, SimulationFailed


class ThreadExecutorDouble:
    """Test double of an executor: runs ``behaviour(task)`` on a thread pool (the real executors
    run an engine in an isolated process); the gate holds every task until the test opens it."""

    def __init__(self, behaviour, workers: int = 2):
        self.capacity = workers
        self.pool = cf.ThreadPoolExecutor(workers)
        self.behaviour = behaviour
        self.gate = threading.Event()
        self.taken = threading.Event()  # set once a worker has taken a task
        self.shut = None

    def submit(self, task):
        def run():
            self.taken.set()
            self.gate.wait(10)
            return self.behaviour(task)
        return self.pool.submit(run)

    def shutdown(self, cancel=False):
        self.shut = cancel
        self.pool.shutdown(wait=True)


def _task(point: int) -> SimulationTask:
    return SimulationTask(point, "numba_dem", ShearCellSpec.preset("tiny"), Path(f"/tmp/p{point}"))


def _behaviour(task):
    if task.point_id == 1:
        raise SimulationFailed("the bed blew up", kind="unstable")
    if task.point_id == 2:
        raise RuntimeError("worker process died")
    return SimpleNamespace(provenance=SimpleNamespace(wall_time=12.5))


def test_every_outcome_comes_back_once_with_failures_as_data():
    executor = ThreadExecutorDouble(_behaviour)
    started = []
    scheduler = Scheduler(executor, on_start=started.append)
    for point in (0, 1, 2):
        scheduler.submit(_task(point), key=("p", point))
    assert len(scheduler) == 3 and scheduler.in_flight() == [("p", 0), ("p", 1), ("p", 2)]
    executor.gate.set()
    finished = []
    while scheduler:
        finished += scheduler.wait(timeout=2.0)
    assert sorted(done.key for done in finished) == [("p", 0), ("p", 1), ("p", 2)]
    by_key = {done.key: done for done in finished}
    assert by_key[("p", 0)].failure is None and by_key[("p", 0)].wall_time == 12.5  # the engine's own time
    assert by_key[("p", 1)].result is None and by_key[("p", 1)].failure.kind == FailureKind.UNSTABLE
    crash = by_key[("p", 2)].failure
    assert crash.kind == "crash" and "RuntimeError: worker process died" in crash.reason
    assert by_key[("p", 2)].wall_time >= 0.0
    assert sorted(started) == [("p", 0), ("p", 1), ("p", 2)]  # each start seen, once
    assert scheduler.wait() == []
    scheduler.shutdown(cancel=True)
    assert executor.shut is True


def test_a_queued_simulation_has_not_started_and_a_key_is_taken_once():
    executor = ThreadExecutorDouble(_behaviour, workers=1)
    scheduler = Scheduler(executor)
    scheduler.submit(_task(0), key="a")
    scheduler.submit(_task(0), key="b")  # queued behind "a" on the one worker
    with pytest.raises(ValueError, match="already in flight"):
        scheduler.submit(_task(0), key="a")
    assert scheduler.started_at("a") is None  # not seen started before a wait looks
    assert executor.taken.wait(5.0)
    assert scheduler.wait(timeout=0.2) == []  # "a" is held at the gate
    assert scheduler.started_at("a") > 0 and scheduler.started_at("b") is None
    executor.gate.set()
    while scheduler:
        scheduler.wait(timeout=2.0)
    assert scheduler.started_at("a") is None and scheduler.started_at("b") is None  # forgotten once returned
    scheduler.shutdown()


def test_a_failure_kind_is_one_of_the_declared_kinds():
    assert SimulationFailed("x", kind="nan").kind is FailureKind.NAN and FailureKind.NAN == "nan"
    assert not SimulationFailed("x", kind="worker_lost").is_physical and SimulationFailed("x").is_physical
    with pytest.raises(ValueError, match=r"unknown failure kind 'exploded'; allowed: \['crash', 'nan'"):
        SimulationFailed("x", kind="exploded")
