"""Executors: where simulations run.

Every simulation runs in a process of its own (:func:`run_isolated`): a crash, a hang or a
segfault of an engine stays there, a timeout kills it, and the process quits by itself if the
process that started it dies. The builtin ``local`` executor runs ``workers`` of them at once on
this machine; ``dask`` (:mod:`calibrax.core.running.dask_executor`) runs them on Dask workers.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import os
import pickle
import signal
import socket
import subprocess
import sys
import threading
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, Protocol, runtime_checkable

from calibrax.core.options import Option
from calibrax.core.sheartest.result import ShearTestResult
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.errors import CalibraxError, SimulationFailed


@dataclass(frozen=True)
class SimulationTask:
    """One simulation to run: ``simulator`` is the plugin name, ``workdir`` its own folder."""

    point_id: int
    simulator: str
    spec: ShearCellSpec
    workdir: Path
    timeout_s: float | None = None

    @property
    def threads(self) -> int:
        """Cores the simulation uses (numba threads, MPI ranks, YADE threads)."""
        return self.spec.numerics.threads

    @property
    def gpus(self) -> int:
        """GPUs the simulation uses: 1 on ``numerics.device: cuda``, else 0."""
        return 1 if self.spec.numerics.device == "cuda" else 0


@runtime_checkable
class Executor(Protocol):
    """Runs :class:`SimulationTask` s; each future gives a ShearTestResult or raises SimulationFailed,
    and reports ``running()`` once a worker has taken its task (the campaign logs the start then,
    not at submission)."""

    name: str

    @property
    def capacity(self) -> int:
        """How many simulations run at once."""
        ...

    def submit(self, task: SimulationTask) -> cf.Future:
        ...

    def shutdown(self, cancel: bool = False) -> None:
        ...


def run_task(task: SimulationTask) -> ShearTestResult:
    """Run one task in this process: find the simulator plugin, simulate, check the result."""
    from calibrax.core.registry import get_manager

    simulator = get_manager().create("simulator", task.simulator)
    Path(task.workdir).mkdir(parents=True, exist_ok=True)
    try:
        result = simulator.simulate(task.spec, Path(task.workdir))
    except CalibraxError:
        raise
    except Exception as exc:  # noqa: BLE001 — a backend bug is a failed simulation, not a dead campaign
        raise SimulationFailed(f"{task.simulator} raised {type(exc).__name__}: {exc}",
                               traceback.format_exc()[-4000:], kind="crash") from exc
    if not result.is_finite():
        raise SimulationFailed(f"{task.simulator} returned non-finite peaks {result.peak_shear_stress.tolist()}",
                               kind="nan")
    return result


class StartTracker:
    """Notes when a worker takes each submitted future (it reports ``running()``): a simulation
    waiting in the queue has not started. ``on_start(future)`` is called once per future, before
    :meth:`wait` returns it finished, so that a start is never logged after its end."""

    def __init__(self, on_start: Callable[[cf.Future], None]) -> None:
        self.on_start = on_start
        self.started: dict[cf.Future, float] = {}  # future → time.monotonic() when it was seen started

    def _note(self, futures: Iterable[cf.Future]) -> None:
        for fut in futures:
            if fut not in self.started and (fut.running() or fut.done()):
                self.started[fut] = time.monotonic()
                self.on_start(fut)

    def wait(self, futures: Iterable[cf.Future], timeout: float = 5.0) -> set[cf.Future]:
        """The futures of ``futures`` that finished within ``timeout`` s (polled every 0.5 s while
        one of them is still queued, to see it start)."""
        futures = set(futures)
        self._note(futures)
        queued = any(fut not in self.started for fut in futures)
        done, _ = cf.wait(futures, timeout=0.5 if queued else timeout, return_when=cf.FIRST_COMPLETED)
        self._note(done)
        return done

    def attempt_time(self, fut: cf.Future) -> float:
        """Seconds since a worker took ``fut`` (0 if it was never seen started)."""
        return time.monotonic() - self.started.get(fut, time.monotonic())


def engine_wall_time(result: ShearTestResult | None, attempt_s: float) -> float:
    """The wall time to store for a simulation, s: the engine's own (its provenance) when it gave
    one, else the attempt's (a failure), never the wait in the executor's queue."""
    if result is not None:
        wall = result.provenance.wall_time
        if isinstance(wall, (int, float)) and math.isfinite(wall) and wall > 0:
            return float(wall)
    return attempt_s


class _Running:
    """The process of one isolated simulation, so that it can be killed from another thread."""

    def __init__(self) -> None:
        self.proc: subprocess.Popen | None = None
        self.cancelled = False

    def kill(self) -> None:
        self.cancelled = True
        if self.proc is not None and self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


ATTEMPTS_LOG = "attempts.log"


def _log_attempt(workdir: Path, event: str) -> None:
    """Append one line to the work folder's ``attempts.log``: UTC time, host, worker pid, event.

    Every start and every end of a simulation attempt is there, so that a folder tells which
    machine ran it, how often it was tried, and that it completed once."""
    stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    with open(Path(workdir) / ATTEMPTS_LOG, "a", encoding="utf-8") as f:
        f.write(f"{stamp} host={socket.gethostname()} pid={os.getpid()} {event}\n")


def run_isolated(task: SimulationTask, timeout_s: float | None = None, handle: _Running | None = None) -> ShearTestResult:
    """Run ``task`` in a fresh Python process (its own session, so a Ctrl-C meant for the campaign
    does not reach it); kill it after ``timeout_s``. The task and its outcome travel as pickle
    files in the task's work folder, which also keeps the engine's own files and ``attempts.log``
    (one line per start and end of an attempt)."""
    workdir = Path(task.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    _log_attempt(workdir, f"started {task.simulator} seed={task.spec.numerics.seed}")
    try:
        result = _run_in_process(task, timeout_s, handle)
    except SimulationFailed as exc:
        _log_attempt(workdir, f"failed ({exc.kind}): {exc.reason.splitlines()[0] if exc.reason else ''}")
        raise
    _log_attempt(workdir, "completed")
    return result


def _run_in_process(task: SimulationTask, timeout_s: float | None, handle: _Running | None) -> ShearTestResult:
    workdir = Path(task.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    request, outcome = workdir / "task.pkl", workdir / "outcome.pkl"
    outcome.unlink(missing_ok=True)
    request.write_bytes(pickle.dumps(task))
    handle = handle or _Running()
    log = open(workdir / "calibrax-worker.log", "wb")
    try:
        handle.proc = subprocess.Popen([sys.executable, "-m", "calibrax.core.running.isolate", str(request), str(outcome),
                                        str(os.getpid())], stdout=log, stderr=subprocess.STDOUT,
                                       start_new_session=True)
        if handle.cancelled:
            handle.kill()
        try:
            code = handle.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            handle.kill()
            handle.proc.wait()
            raise SimulationFailed(f"timed out after {timeout_s:g} s", _tail(workdir), kind="timeout") from None
    finally:
        log.close()
    if handle.cancelled:
        raise SimulationFailed("cancelled", kind="cancelled")
    if not outcome.exists():
        how = f"signal {-code}" if code < 0 else f"exit code {code}"
        raise SimulationFailed(f"simulation process died ({how})", _tail(workdir), kind="crash")
    message = pickle.loads(outcome.read_bytes())
    if message[0] == "ok":
        return message[1]
    raise SimulationFailed(message[1], message[2] or _tail(workdir), kind=message[3])


def _tail(workdir: Path, lines: int = 40) -> str:
    path = Path(workdir) / "calibrax-worker.log"
    if not path.exists():
        return ""
    return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])


class LocalExecutor:
    """Isolated simulations on this machine, ``workers`` at once, each killed after ``timeout_s``."""

    name = "local"
    OPTIONS = {"workers": Option(int, low=1), "timeout_s": Option(float, low=0.0, low_open=True)}

    def __init__(self, workers: int = 1, timeout_s: float | None = None) -> None:
        self.workers = workers
        self.timeout_s = timeout_s
        self._threads = cf.ThreadPoolExecutor(max_workers=workers, thread_name_prefix="calibrax-sim")
        self._live: set[_Running] = set()
        self._lock = threading.Lock()
        self._cancelled = False

    @property
    def capacity(self) -> int:
        return self.workers

    def submit(self, task: SimulationTask) -> cf.Future:
        return self._threads.submit(self._run, task)

    def _run(self, task: SimulationTask) -> ShearTestResult:
        handle = _Running()
        with self._lock:
            if self._cancelled:
                raise SimulationFailed("cancelled before it started", kind="cancelled")
            self._live.add(handle)
        try:
            timeout = task.timeout_s if task.timeout_s is not None else self.timeout_s
            return run_isolated(task, timeout, handle)
        finally:
            with self._lock:
                self._live.discard(handle)

    def shutdown(self, cancel: bool = False) -> None:
        if cancel:
            with self._lock:
                self._cancelled = True
                for handle in list(self._live):
                    handle.kill()
        self._threads.shutdown(wait=True, cancel_futures=cancel)
