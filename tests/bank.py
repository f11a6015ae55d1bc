"""A session-wide bank of real-engine shear tests, run two at a time in the background.

Each test module *declares* at import the simulations it may read (:func:`declare`), and each test
that reads some names them with the ``bank`` marker (``@pytest.mark.bank(NAME, ...)``, or a module's
``pytestmark``). When collection ends, the session submits the jobs of the *selected* tests only (a
job of a test that ``-m`` or ``-k`` left out never runs) to two spawned worker processes, most
expensive first; the tests that read them (:meth:`SimulationBank.result`) wait only for their own.
A job that two tests or two modules name runs once.

Under pytest-xdist the session's processes share one bank through a folder: the first process to
finish collecting owns it (runs the jobs, writes each outcome there), the others read the outcomes
from it; the owner waits for all of its jobs before it exits.

Every shear test the bank finishes is recorded (backend, engine version, wall time) in the session
folder's ``engine-runs.jsonl``: the test tiers check from it that every engine really ran
(``pytest --tier``, tests/conftest.py).
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import multiprocessing
import os
import pickle
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
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


#: how long a reader in another process waits for a job's outcome, s (the full tier takes 30 min)
WAIT_LIMIT_S = 3600.0
#: the session folder's file of finished shear tests (JSON lines)
ENGINE_RUNS = "engine-runs.jsonl"


def record_engine_run(session: Path, name: str, result: ShearTestResult) -> None:
    """Append one finished shear test to the session folder's :data:`ENGINE_RUNS`: the job's name,
    the backend, the engine's own version string, its wall time (s) and particle count."""
    prov = result.provenance
    line = json.dumps({"job": name, "backend": prov.backend, "engine_version": prov.engine_version,
                       "wall_time": prov.wall_time, "particles": prov.particle_count})
    with open(Path(session) / ENGINE_RUNS, "a", encoding="utf-8") as fh:  # one short line: appends do not interleave
        fh.write(line + "\n")


def read_engine_runs(session: Path) -> list[dict]:
    """The records :func:`record_engine_run` appended in the session folder ([] if none)."""
    path = Path(session) / ENGINE_RUNS
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def _write_atomically(path: Path, data: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


class SimulationBank:
    """The ``selected`` declared jobs of one session (tests/conftest.py refuses an undeclared name), shared by its processes through the folder
    ``session`` (``bank/`` in it: the owner, each job's work folder and outcome). The owner runs
    them in ``workers`` spawned processes, each in its own work folder (kept, so that tests can read
    the engines' input and log files)."""

    def __init__(self, session: Path, selected: set[str], workers: int = 2):
        self.session = Path(session)
        self.folder = self.session / "bank"
        self.folder.mkdir(parents=True, exist_ok=True)
        self.selected = set(selected)
        self.workers = workers
        self._pool: cf.ProcessPoolExecutor | None = None
        self._futures: dict[str, cf.Future] = {}

    def start(self) -> None:
        """Submit every selected job, most expensive first, unless another process of the session
        already owns the bank (once; nothing if none is selected)."""
        if self._pool is not None or not self.selected:
            return
        try:
            os.close(os.open(self.folder / "owner", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return  # another process of this session runs the jobs
        self._pool = cf.ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"))
        for name in sorted(self.selected, key=lambda n: (-JOBS[n].cost, n)):
            self._submit(name, JOBS[name])

    def _file(self, name: str, suffix: str) -> Path:
        return self.folder / (name.replace("/", "__") + suffix)

    def _submit(self, name: str, job: Job) -> None:
        workdir = tempfile.mkdtemp(prefix=name.replace("/", "-") + "-", dir=self.folder)
        _write_atomically(self._file(name, ".workdir"), workdir.encode())
        future = self._pool.submit(_simulate, job, workdir)
        future.add_done_callback(lambda f: self._publish(name, f))
        self._futures[name] = future

    def _publish(self, name: str, future: cf.Future) -> None:
        """Write a finished job's outcome for every process of the session (the pool's thread)."""
        if future.cancelled():
            return
        error = future.exception()
        outcome = ("error", error) if error is not None else ("ok", future.result())
        try:
            data = pickle.dumps(outcome)
        except Exception as exc:  # noqa: BLE001 — an error that does not pickle still reaches the reader
            data = pickle.dumps(("error", RuntimeError(f"bank job {name} failed: {error!r} ({exc})")))
        _write_atomically(self._file(name, ".outcome"), data)
        if error is None:
            record_engine_run(self.session, name, future.result())

    def result(self, name: str) -> ShearTestResult:
        """The result of the selected job ``name`` (waits for it; re-raises its error)."""
        self._check(name)
        if name in self._futures:
            return self._futures[name].result()
        kind, value = pickle.loads(self._wait_for(self._file(name, ".outcome")).read_bytes())
        if kind == "error":
            raise value
        return value

    def workdir(self, name: str) -> Path:
        """The folder the job ``name`` ran in."""
        self._check(name)
        return Path(self._wait_for(self._file(name, ".workdir")).read_text())

    def _wait_for(self, path: Path) -> Path:
        """``path`` once the bank's owner has written it; a clear error after :data:`WAIT_LIMIT_S`
        (the owner died, or the jobs take far longer than any tier)."""
        deadline = time.monotonic() + WAIT_LIMIT_S
        while not path.is_file():
            if time.monotonic() > deadline:
                raise TimeoutError(f"no bank outcome {path.name} after {WAIT_LIMIT_S:.0f} s in {self.folder}")
            time.sleep(0.5)
        return path

    def _check(self, name: str) -> None:
        if name not in self.selected:
            raise KeyError(f"bank job {name!r} is read by a test that does not name it: mark the test "
                           f"(or its module) with @pytest.mark.bank({name!r}), so that the session runs it")

    def close(self, wait: bool = True) -> None:
        """The owner: wait for every job (other processes may still read them), or with
        ``wait=False`` cancel what has not started and stop the workers."""
        if self._pool is None:
            return
        if wait:
            self._pool.shutdown(wait=True)
            return
        for process in list(getattr(self._pool, "_processes", {}).values()):
            process.terminate()
        self._pool.shutdown(wait=False, cancel_futures=True)


# ----------------------------------------------------------------------------- shared declarations
#: The smoke test: the ``tiny`` cell (577 particles) and the whole procedure (pour, consolidation,
#: four preshears and shear steps, the unloads and settles between them) at the cheapest settings
#: that still run every phase of an engine's script: rotations of 0.02 rad, a soft material
#: (E = 1 GPa: a 2.9× larger time step than Table 1's 25 GPa) and 0.2 Δt_crit. Its peaks are
#: the elastic rise of each window, not the powder's strength: structure is checked on it, physics
#: on the ``tiny`` runs. Measured alone on one core: numba_dem ≈ 6 s, LIGGGHTS ≈ 15 s, YADE ≈ 60 s.
SMOKE_MATERIAL = {"youngs_modulus": 1.0e9}
SMOKE_PROCEDURE = {"preshear_rotation": 0.02, "shear_rotation": 0.02, "settle_time": 0.002, "peak_window": 0.01,
                   "preshear_max_rotation": 0.04, "steady_window": 0.01, "steady_tolerance": 0.05}
SMOKE_NUMERICS = {"dt_fraction": 0.2, "threads": 1}


def check_preshears_and_insertion(spec: ShearCellSpec, result) -> None:
    """What every backend's real run must show of the steady preshear and the blade insertion:
    each preshear turned between its minimum and its cap (± one sample); its drift
    (``sheartest.preshear_drift``) is within the tolerance unless it stopped at the cap, and then
    the result warns; the blades went in (the head's face down to within a tenth of a radius of
    the poured bed's top) or the result warns that they did not."""
    p = spec.procedure
    one = p.rotation_rate * spec.numerics.sample_interval * 1.01
    pre = [s for s in result.steps if s.kind == "preshear"]
    assert result.preshear_rotation.shape == result.preshear_drift.shape == (len(pre),)
    for k, step in enumerate(pre):
        turned = step.rotation[-1]  # rotation is counted from 0 at the step's start
        assert result.preshear_rotation[k] == turned
        assert p.preshear_rotation - one <= turned <= (p.preshear_max_rotation or p.preshear_rotation) + one, k
        drift = result.preshear_drift[k]
        assert np.isfinite(drift), k
        if drift > p.steady_tolerance:
            assert turned >= p.preshear_max_rotation - one, (k, drift, turned)
    unsteady = int(np.sum(result.preshear_drift > p.steady_tolerance))
    warned = [w for w in result.warnings if "ended before τ/σ was steady" in w]
    assert bool(warned) == (unsteady > 0) and (not warned or warned[0].startswith(f"{unsteady} of ")), warned
    gap = result.provenance.extra["insertion_gap_radii"]
    assert gap <= 0.1 or any("blade insertion" in w for w in result.warnings), gap


def smoke_spec(seed: int = 0) -> ShearCellSpec:
    """The smoke test's spec (:data:`SMOKE_PROCEDURE`) at ``seed``."""
    return ShearCellSpec.preset("tiny").replace(material=SMOKE_MATERIAL, procedure=SMOKE_PROCEDURE,
                                                numerics={**SMOKE_NUMERICS, "seed": seed})


def declare_smoke(backend: str, tag: str = "smoke") -> str:
    """Declare the smoke test on ``backend`` as ``{backend}/{tag}/s0``; another ``tag`` runs the
    same spec again (numba_dem's determinism check)."""
    return declare(f"{backend}/{tag}/s0", backend, smoke_spec())


#: half the ``tiny`` preset's rotations: enough for the base slip (read over each window's second
#: half), not for a steady state
SHORT_ROTATIONS = {"preshear_rotation": 0.06, "preshear_max_rotation": None, "shear_rotation": 0.06}


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
