"""A session-wide bank of real-engine shear tests, run two at a time in the background.

Each test module *declares* at import the simulations it needs (:func:`declare`); the session
starts all the declared ones of the collected modules at its first test, in two spawned worker
processes, most expensive first, and the tests that read them (:meth:`SimulationBank.result`) run
last and wait only for their own. Single simulations that modules used to run one after another, each on one core, now run
side by side and alongside the rest of the suite; one declared by two modules runs once.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import tempfile
from dataclasses import dataclass
from pathlib import Path

from calibrax.core.sheartest import ShearCellSpec, ShearTestResult

#: relative wall time of one ``tiny`` test per backend (numba_dem = 1), to run the longest first
BACKEND_COST = {"numba_dem": 1.0, "liggghts": 2.0, "yade": 12.0}


@dataclass(frozen=True)
class Job:
    """One real shear test: the backend (registered simulator name) and its spec."""

    backend: str
    spec: ShearCellSpec

    @property
    def cost(self) -> float:
        """Relative wall time: backend factor × simulated rotation (rad)."""
        p = self.spec.procedure
        rotation = len(p.shear_stresses) * (p.preshear_rotation + p.shear_rotation)
        return BACKEND_COST.get(self.backend, 1.0) * rotation


#: name → job, filled by the test modules as pytest imports them
JOBS: dict[str, Job] = {}


def declare(name: str, backend: str, spec: ShearCellSpec) -> str:
    """Declare a simulation under ``name`` (the same name may be declared again only for the same
    job); returns the name."""
    job = Job(backend, spec)
    if JOBS.setdefault(name, job) != job:
        raise ValueError(f"bank job {name!r} declared twice with different specs")
    return name


def _simulate(job: Job, workdir: str) -> ShearTestResult:
    from calibrax import get_manager

    return get_manager().create("simulator", job.backend).simulate(job.spec, Path(workdir))


class SimulationBank:
    """Runs the declared jobs in ``workers`` spawned processes, each in its own folder under
    ``root`` (kept, so that tests can read the engines' input and log files)."""

    def __init__(self, root: Path, workers: int = 2):
        self.root = Path(root)
        self.workers = workers
        self._pool: cf.ProcessPoolExecutor | None = None
        self._futures: dict[str, cf.Future] = {}

    def start(self) -> None:
        """Submit every declared job, most expensive first (once)."""
        if self._pool is not None:
            return
        self._pool = cf.ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"))
        for name, job in sorted(JOBS.items(), key=lambda item: -item[1].cost):
            self._submit(name, job)

    def _submit(self, name: str, job: Job) -> None:
        workdir = tempfile.mkdtemp(prefix=name.replace("/", "-") + "-", dir=self.root)
        self._futures[name] = self._pool.submit(_simulate, job, workdir)
        self._futures[name].workdir = Path(workdir)

    def result(self, name: str) -> ShearTestResult:
        """The result of the declared job ``name`` (waits for it; re-raises its error)."""
        return self._future(name).result()

    def workdir(self, name: str) -> Path:
        """The folder the job ``name`` ran in."""
        return self._future(name).workdir

    def _future(self, name: str) -> cf.Future:
        if name not in JOBS:
            raise KeyError(f"bank job {name!r} was never declared (declare it at module level)")
        self.start()
        if name not in self._futures:  # declared after the start (a module imported late)
            self._submit(name, JOBS[name])
        return self._futures[name]

    def close(self) -> None:
        """Cancel what has not started and stop the workers."""
        if self._pool is not None:
            for process in list(getattr(self._pool, "_processes", {}).values()):
                process.terminate()
            self._pool.shutdown(wait=False, cancel_futures=True)


# ----------------------------------------------------------------------------- shared declarations
#: half the ``tiny`` preset's rotations: enough for the base slip (read over each window's second
#: half), not for a steady state
SHORT_ROTATIONS = {"preshear_rotation": 0.06, "shear_rotation": 0.06}


def declare_tiny(backend: str, seed: int = 0, tag: str = "tiny", **changes) -> str:
    """Declare the ``tiny`` preset (with ``changes`` as for :meth:`ShearCellSpec.replace`) at
    ``seed`` as ``{backend}/{tag}/s{seed}``; the name is the same from every module that asks."""
    spec = ShearCellSpec.preset("tiny").replace(**changes) if changes else ShearCellSpec.preset("tiny")
    return declare(f"{backend}/{tag}/s{seed}", backend, spec.replace(numerics={"seed": seed}))


def declare_short(backend: str, case: str, seed: int = 0, **changes) -> str:
    """Declare ``tiny`` at half its rotations (:data:`SHORT_ROTATIONS`) with ``changes`` as
    ``{backend}/short-{case}/s{seed}``."""
    procedure = {**SHORT_ROTATIONS, **changes.pop("procedure", {})}
    return declare_tiny(backend, seed, f"short-{case}", procedure=procedure, **changes)
