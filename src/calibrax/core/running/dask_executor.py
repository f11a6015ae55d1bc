"""The ``dask`` executor: simulations on Dask workers — a running scheduler, a LocalCluster, or
SLURM/PBS jobs through dask-jobqueue. No home-made scheduling: Dask places, retries and
reschedules; calibrax only submits.

* Each simulation still runs in its own process on the worker (:func:`run_isolated`), so a crash or
  a timeout kills that simulation only.
* Cores are reserved through Dask worker resources: every worker offers ``cores`` units of the
  resource ``cores`` and a simulation asks for ``spec.numerics.threads`` of them, so a worker is
  never oversubscribed by multi-threaded engines. Likewise GPUs: a worker started with ``gpus``
  offers that many units of the resource ``GPU``, and a simulation on ``numerics.device: cuda``
  asks for one (a scheduler given by ``address`` needs workers started with ``--resources GPU=1``).
* A worker that dies mid-simulation has its simulation rescheduled by the scheduler, up to
  ``retries`` times (``distributed.scheduler.allowed-failures``; set on the scheduler calibrax
  starts, the scheduler's own setting for ``address``); the orphaned simulation quits without
  reporting, so a simulation completes once.
* Work folders are under the campaign's ``workdir``; on a cluster it must be a shared path.

Only the campaign process holds the model and writes the store.
"""

from __future__ import annotations

import concurrent.futures as cf
import threading
import uuid
from typing import Any

from calibrax.core.running.executor import SimulationTask, run_isolated
from calibrax.core.options import Option
from calibrax.errors import ConfigError, SimulationFailed

CLUSTERS = ("local", "slurm", "pbs")


def _resources(cores: int, gpus: int) -> dict[str, int]:
    """The Dask resources one worker offers: ``cores``, and ``GPU`` where it has GPUs."""
    return {"cores": cores, **({"GPU": gpus} if gpus else {})}


def _job_options(cores: int, gpus: int, memory: str | None, walltime: str | None, queue: str | None,
                 account: str | None, job_extra_directives: list[str] | None) -> dict[str, Any]:
    offer = ",".join(f"{k}={v}" for k, v in _resources(cores, gpus).items())
    out: dict[str, Any] = {"cores": cores, "processes": 1, "memory": memory,
                           "worker_extra_args": ["--resources", offer]}
    for key, value in (("walltime", walltime), ("queue", queue), ("account", account),
                       ("job_extra_directives", job_extra_directives)):
        if value:
            out[key] = value
    return out


class DaskExecutor:
    """Simulations on Dask. Give ``address`` (a running scheduler) or ``cluster`` (local, slurm, pbs)."""

    name = "dask"
    OPTIONS = {"address": str, "cluster": Option(str, choices=tuple(CLUSTERS)), "workers": Option(int, low=1),
               "cores": Option(int, low=1), "gpus": Option(int, low=0), "memory": str, "walltime": str, "queue": str, "account": str,
               "job_extra_directives": list, "log_directory": str, "timeout_s": Option(float, low=0.0, low_open=True),
               "retries": Option(int, low=0)}

    def __init__(self, address: str | None = None, cluster: str | None = None, workers: int = 2, cores: int = 1,
                 gpus: int = 0, memory: str | None = None, walltime: str | None = None, queue: str | None = None,
                 account: str | None = None, job_extra_directives: list[str] | None = None,
                 log_directory: str | None = None, timeout_s: float | None = None, retries: int = 2) -> None:
        import importlib.util

        if importlib.util.find_spec("distributed") is None:
            raise ConfigError("executor", "the dask executor needs Dask: pip install 'calibrax[dask]'")
        if cluster in ("slurm", "pbs") and importlib.util.find_spec("dask_jobqueue") is None:
            raise ConfigError("executor.cluster", "slurm and pbs need dask-jobqueue: pip install 'calibrax[dask]'")
        if (address is None) == (cluster is None):
            raise ConfigError("executor", "give exactly one of 'address' (tcp://HOST:PORT of a running scheduler) "
                              f"or 'cluster' (one of {list(CLUSTERS)})")
        if address is not None and not address.startswith(("tcp://", "tls://", "inproc://", "ucx://")):
            raise ConfigError("executor.address", f"must look like tcp://HOST:PORT, got {address!r}")
        if cluster in ("slurm", "pbs") and not memory:
            raise ConfigError("executor.memory", f"is required for cluster {cluster} (e.g. '8GB' per job)")
        self.address, self.cluster_kind, self.workers, self.cores, self.gpus = address, cluster, workers, cores, gpus
        self.job = _job_options(cores, gpus, memory, walltime, queue, account, job_extra_directives)
        if log_directory:
            self.job["log_directory"] = log_directory  # where the batch system writes the jobs' output
        self.timeout_s, self.retries = timeout_s, retries
        self._client = None
        self._cluster = None
        self._futures: set = set()
        self._lock = threading.Lock()

    # ------------------------------------------------------------------------------------------
    def make_cluster(self):
        """The cluster object (not started for jobqueue until scaled); LocalCluster starts at once."""
        import dask

        dask.config.set({"distributed.scheduler.allowed-failures": self.retries})
        if self.cluster_kind == "local":
            from dask.distributed import LocalCluster

            return LocalCluster(n_workers=self.workers, threads_per_worker=self.cores, processes=True,
                                resources=_resources(self.cores, self.gpus), dashboard_address=None)
        import dask_jobqueue

        cls = dask_jobqueue.SLURMCluster if self.cluster_kind == "slurm" else dask_jobqueue.PBSCluster
        return cls(**self.job)

    def job_script(self) -> str:
        """The batch script dask-jobqueue would submit (slurm/pbs only)."""
        if self.cluster_kind not in ("slurm", "pbs"):
            raise ConfigError("executor.cluster", "job scripts exist for slurm and pbs only")
        cluster = self.make_cluster()
        try:
            return cluster.job_script()
        finally:
            cluster.close()

    def _client_or_start(self):
        with self._lock:
            if self._client is None:
                from dask.distributed import Client

                if self.address is not None:
                    self._client = Client(self.address)
                else:
                    self._cluster = self.make_cluster()
                    if self.cluster_kind != "local":
                        self._cluster.scale(jobs=self.workers)
                    self._client = Client(self._cluster)
            return self._client

    @property
    def capacity(self) -> int:
        """Simulation slots: the scheduler's ``cores`` resources (1-thread simulations), else workers × cores."""
        if self._client is not None and self.address is not None:
            info = self._client.scheduler_info().get("workers", {})
            total = sum(int(w.get("resources", {}).get("cores", w.get("nthreads", 1))) for w in info.values())
            if total:
                return total
        return self.workers * self.cores

    def submit(self, task: SimulationTask) -> cf.Future:
        client = self._client_or_start()
        key = f"calibrax-p{task.point_id}-{uuid.uuid4().hex[:8]}"
        timeout = task.timeout_s if task.timeout_s is not None else self.timeout_s
        dask_future = client.submit(run_isolated, task, timeout, key=key, pure=False,
                                    resources=_resources(task.threads, task.gpus))
        result: cf.Future = cf.Future()
        # a Dask client does not see when a worker takes a task: the campaign counts it as started
        # once it is handed to the cluster, whose scheduler queues it
        result.set_running_or_notify_cancel()
        with self._lock:
            self._futures.add(dask_future)

        def done(f) -> None:
            with self._lock:
                self._futures.discard(f)
            try:
                result.set_result(f.result())
            except SimulationFailed as exc:
                result.set_exception(exc)
            except BaseException as exc:  # noqa: BLE001 — KilledWorker, cancellation, lost scheduler…
                kind = "worker_lost" if type(exc).__name__ == "KilledWorker" else (
                    "cancelled" if type(exc).__name__ == "CancelledError" else "crash")
                result.set_exception(SimulationFailed(f"dask: {type(exc).__name__}: {exc}", kind=kind))

        dask_future.add_done_callback(done)
        return result

    def shutdown(self, cancel: bool = False) -> None:
        with self._lock:
            client, cluster, futures = self._client, self._cluster, list(self._futures)
            self._client = self._cluster = None
        if client is not None:
            if cancel and futures:
                client.cancel(futures, force=True)
            client.close()
        if cluster is not None:
            cluster.close()
