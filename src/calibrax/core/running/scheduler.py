"""The one loop that runs simulations for every study: submit them to an executor, see when a
worker takes each, and turn each finished one into an outcome, a result or a failure, the same way
for a campaign, a cross-check, a convergence study, a diagnosis design and a benchmark.

What to run next is the caller's business (a campaign asks its model, a study has a fixed list), as
in Ax's orchestrator the generation strategy is; the scheduler only deploys, tracks and records:

    scheduler = Scheduler(executor, on_start=lambda key: log.info("%s starts", key))
    scheduler.submit(task, key=(point_id, index))
    while scheduler:
        for done in scheduler.wait():
            store(done.key, done.result, done.failure, done.wall_time)

A failure is data: the engine's :class:`~calibrax.errors.SimulationFailed` is passed on as it is,
and any other exception the executor raises for one simulation (a lost worker, a pickling error) is
that simulation's failure of kind ``crash``, never the caller's crash.
"""

from __future__ import annotations

import concurrent.futures as cf
import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass

from calibrax.core.running.executor import SimulationTask, StartTracker, engine_wall_time
from calibrax.core.sheartest.result import ShearTestResult
from calibrax.errors import SimulationFailed


@dataclass(frozen=True)
class Finished:
    """One finished simulation.

    Attributes:
        key: what the caller submitted it under.
        result: the result, or None when it failed.
        failure: why it failed, or None.
        wall_time: the engine's own wall time when it gave one, else the attempt's, s (never the
            time it waited in the executor's queue).
    """

    key: Hashable
    result: ShearTestResult | None
    failure: SimulationFailed | None
    wall_time: float


def outcome(fut: cf.Future) -> tuple[ShearTestResult | None, SimulationFailed | None]:
    """(result, None) or (None, failure) of a finished future; an executor fault is the
    simulation's failure (kind ``crash``)."""
    try:
        return fut.result(), None
    except SimulationFailed as exc:
        return None, exc
    except Exception as exc:  # noqa: BLE001 — an executor fault is this simulation's failure
        return None, SimulationFailed(f"executor error {type(exc).__name__}: {exc}", kind="crash")


class Scheduler:
    """Simulations in flight on one executor, by the caller's key.

    ``on_start(key)`` is called once per simulation when a worker takes it (a simulation waiting in
    the executor's queue has not started), always before :meth:`wait` returns it finished.
    """

    def __init__(self, executor, on_start: Callable[[Hashable], None] | None = None) -> None:
        self.executor = executor
        self._keys: dict[cf.Future, Hashable] = {}
        self._started: dict[Hashable, float] = {}
        self._on_start = on_start
        self._starts = StartTracker(self._note_start)

    def _note_start(self, fut: cf.Future) -> None:
        key = self._keys[fut]
        self._started[key] = time.monotonic()
        if self._on_start is not None:
            self._on_start(key)

    def submit(self, task: SimulationTask, key: Hashable) -> None:
        """Queue ``task`` on the executor under ``key`` (unique among those in flight)."""
        if key in self._keys.values():
            raise ValueError(f"a simulation is already in flight under {key!r}")
        self._keys[self.executor.submit(task)] = key

    def __len__(self) -> int:
        """Simulations submitted and not yet returned by :meth:`wait`."""
        return len(self._keys)

    @property
    def capacity(self) -> int:
        """Simulations the executor runs at once (at least 1)."""
        return max(1, int(getattr(self.executor, "capacity", 1)))

    def in_flight(self) -> list[Hashable]:
        """The keys of the simulations submitted and not yet returned, in submission order."""
        return list(self._keys.values())

    def started_at(self, key: Hashable) -> float | None:
        """``time.monotonic()`` when a worker took the simulation ``key``, or None while it is queued."""
        return self._started.get(key)

    def wait(self, timeout: float = 5.0) -> list[Finished]:
        """The simulations that finished within ``timeout`` s (sooner while one is still queued, to
        see it start), in submission order; each is returned once."""
        if not self._keys:
            return []
        done = self._starts.wait(self._keys, timeout)
        out = []
        for fut in [f for f in self._keys if f in done]:
            key = self._keys.pop(fut)
            result, failure = outcome(fut)
            wall = engine_wall_time(result, self._starts.attempt_time(fut))
            self._starts.started.pop(fut, None)
            self._started.pop(key, None)
            out.append(Finished(key, result, failure, wall))
        return out

    def shutdown(self, cancel: bool = False) -> None:
        """Shut the executor down (``cancel``: kill what runs and drop what is queued)."""
        self.executor.shutdown(cancel=cancel)


__all__ = ["Finished", "Scheduler", "outcome"]
