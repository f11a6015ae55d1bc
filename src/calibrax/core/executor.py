"""Executors: where simulations run. The builtin ``local`` one runs each simulation in its own
process (so a crash, a hang or a segfault stays there), at most ``workers`` at a time, and kills
one that runs past its timeout. ``dask`` (issue 10) plugs in through the same interface.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing as mp
import os
import threading
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, runtime_checkable

from calibrax.core.sheartest import ShearCellSpec, ShearTestResult
from calibrax.errors import CalibraxError, SimulationFailed


@dataclass(frozen=True)
class SimulationTask:
    """One simulation to run: ``simulator`` is the plugin name, ``workdir`` its own folder."""

    point_id: int
    simulator: str
    spec: ShearCellSpec
    workdir: Path
    timeout_s: float | None = None


@runtime_checkable
class Executor(Protocol):
    """Runs :class:`SimulationTask` s; each future gives a ShearTestResult or raises SimulationFailed."""

    name: str

    def submit(self, task: SimulationTask) -> cf.Future:
        ...

    def shutdown(self, cancel: bool = False) -> None:
        ...


def run_task(task: SimulationTask) -> ShearTestResult:
    """Run one task in this process: find the simulator plugin, simulate, check the result."""
    from calibrax.plugins.manager import get_manager

    simulator = get_manager().create("simulator", task.simulator)
    Path(task.workdir).mkdir(parents=True, exist_ok=True)
    try:
        result = simulator.simulate(task.spec, Path(task.workdir))
    except SimulationFailed:
        raise
    except CalibraxError:
        raise
    except Exception as exc:  # noqa: BLE001 — a backend bug is a failed simulation, not a dead campaign
        raise SimulationFailed(f"{task.simulator} raised {type(exc).__name__}: {exc}",
                               traceback.format_exc()[-4000:], kind="crash") from exc
    if not result.is_finite():
        raise SimulationFailed(f"{task.simulator} returned non-finite peaks {result.peak_shear_stress.tolist()}",
                               kind="nan")
    return result


def _watch_parent(parent_pid: int) -> None:
    """End this child if the campaign process dies (kill -9 leaves no one to read the result)."""
    while True:
        if os.getppid() != parent_pid:
            os._exit(3)
        time.sleep(0.5)


def _child_main(task: SimulationTask, conn, parent_pid: int) -> None:
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True).start()
    try:
        conn.send(("ok", run_task(task)))
    except SimulationFailed as exc:
        conn.send(("failed", exc.reason, exc.log_tail, exc.kind))
    except BaseException as exc:  # noqa: BLE001 — report anything to the parent as a failure
        conn.send(("failed", f"{type(exc).__name__}: {exc}", traceback.format_exc()[-4000:], "crash"))
    finally:
        conn.close()


class LocalExecutor:
    """Process per simulation, ``workers`` at once, each killed after ``timeout_s`` seconds."""

    name = "local"
    OPTIONS = {"workers": int, "timeout_s": float}

    def __init__(self, workers: int = 1, timeout_s: float | None = None) -> None:
        self.workers = workers
        self.timeout_s = timeout_s
        self._threads = cf.ThreadPoolExecutor(max_workers=workers, thread_name_prefix="calibrax-sim")
        self._ctx = mp.get_context("spawn")
        self._live: set = set()
        self._lock = threading.Lock()
        self._cancelled = False

    def submit(self, task: SimulationTask) -> cf.Future:
        return self._threads.submit(self._run, task)

    def _run(self, task: SimulationTask) -> ShearTestResult:
        if self._cancelled:
            raise SimulationFailed("cancelled before it started", kind="cancelled")
        timeout = task.timeout_s if task.timeout_s is not None else self.timeout_s
        recv, send = self._ctx.Pipe(duplex=False)
        proc = self._ctx.Process(target=_child_main, args=(task, send, os.getpid()), daemon=True,
                                 name=f"calibrax-point-{task.point_id}")
        with self._lock:
            self._live.add(proc)
        try:
            proc.start()
            send.close()
            deadline = None if timeout is None else time.monotonic() + timeout
            message = None
            while message is None:
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    raise SimulationFailed(f"timed out after {timeout:g} s", kind="timeout")
                if recv.poll(0.2 if left is None else min(0.2, left)):
                    try:
                        message = recv.recv()
                    except EOFError:
                        break
                elif not proc.is_alive():
                    if recv.poll(0.1):
                        continue
                    break
            if message is None:
                proc.join(1.0)
                if self._cancelled:
                    raise SimulationFailed("cancelled", kind="cancelled")
                raise SimulationFailed(f"simulation process died (exit code {proc.exitcode})", kind="crash")
            if message[0] == "ok":
                return message[1]
            raise SimulationFailed(message[1], message[2], kind=message[3])
        finally:
            if proc.is_alive():
                proc.kill()
            proc.join(5.0)
            recv.close()
            with self._lock:
                self._live.discard(proc)

    def shutdown(self, cancel: bool = False) -> None:
        if cancel:
            self._cancelled = True
            with self._lock:
                for proc in list(self._live):
                    if proc.is_alive():
                        proc.kill()
        self._threads.shutdown(wait=True, cancel_futures=cancel)
