"""The dask executor: a real dask.distributed scheduler with worker processes on localhost runs a
campaign on the real numba_dem backend, and a worker killed mid-simulation loses nothing; the
same with the analytic test double under a tighter schedule; the SLURM job script rendered from
a calibrax YAML."""

from __future__ import annotations

import math
import pathlib
import signal
import subprocess
import sys
import time

import psutil
import pytest
import yaml

from calibrax import CampaignStore, load_config
from calibrax.core.registry import get_manager
from tests.conftest import ROOT, calibrax_cli, double_env, write_backend_campaign, write_double_campaign


def _kill_worker_of_first_simulation(proc: subprocess.Popen, after_s: float, deadline_s: float) -> str | None:
    """SIGKILL the Dask worker process of the first isolated simulation seen, ``after_s`` into it."""
    deadline = time.monotonic() + deadline_s
    while time.monotonic() < deadline and proc.poll() is None:
        for child in psutil.Process(proc.pid).children(recursive=True):
            try:
                if "calibrax.core.running.isolate" in " ".join(child.cmdline()):
                    time.sleep(after_s)  # mid-simulation
                    worker = child.parent()
                    task = child.cmdline()[-3]
                    worker.send_signal(signal.SIGKILL)
                    return task
            except psutil.NoSuchProcess:
                continue
        time.sleep(0.1)
    return None


@pytest.mark.numba_dem
def test_dask_campaign_on_numba_dem_survives_a_killed_worker(tmp_path):
    """A real scheduler and 2 worker processes run a numba_dem campaign (2 Sobol points, one qEI
    batch of 2, on the smoke test's cell: about 6 s per simulation) to the end while one worker is
    SIGKILLed mid-simulation: every simulation is accounted for, the killed one ran again
    elsewhere, and none completed twice."""
    path = write_backend_campaign(tmp_path, "numba_dem", executor={"name": "dask", "cluster": "local", "workers": 2,
                                                                   "retries": 2, "timeout_s": 3000})
    proc = subprocess.Popen([sys.executable, "-m", "calibrax.cli", "run", str(path)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed_task = _kill_worker_of_first_simulation(proc, after_s=2.0, deadline_s=180)
    out, err = proc.communicate(timeout=3600)
    assert killed_task is not None, "no simulation was caught running"
    assert proc.returncode == 0, err[-3000:]
    points = CampaignStore(tmp_path / "runs/campaign.h5").points()
    assert len(points) == 2 + 2
    assert all(p.status == "done" for p in points), [p.sims for p in points if p.status != "done"]
    assert all(math.isfinite(p.metric.value) for p in points)
    folders = sorted((tmp_path / "runs/campaign.runs").iterdir())
    assert len(folders) == 4
    attempts = {f.name: (f / "attempts.log").read_text().splitlines() for f in folders}
    for name, lines in attempts.items():
        assert sum(line.endswith(" completed") for line in lines) == 1, (name, lines)
    killed_folder = attempts[pathlib.Path(killed_task).parent.name]
    assert sum(" started numba_dem" in line for line in killed_folder) == 2, killed_folder
    assert "numba_dem" in err and "seed" in err  # the log says which engine ran which point with which seed


def test_worker_killed_mid_simulation_campaign_still_finishes(tmp_path):
    path = write_double_campaign(tmp_path, budget={"initial": 4, "iterations": 2},
                                 executor={"name": "dask", "cluster": "local", "workers": 2, "retries": 3})
    env = double_env(CALIBRAX_DOUBLE_SLEEP="3")
    proc = subprocess.Popen([sys.executable, "-m", "calibrax.cli", "run", str(path)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed = None
    deadline = time.monotonic() + 120
    while killed is None and time.monotonic() < deadline and proc.poll() is None:
        for child in psutil.Process(proc.pid).children(recursive=True):
            try:
                if "calibrax.core.running.isolate" in " ".join(child.cmdline()):
                    time.sleep(1.0)  # mid-simulation
                    worker = child.parent()
                    killed = (worker.pid, " ".join(child.cmdline()))
                    worker.send_signal(signal.SIGKILL)
                    break
            except psutil.NoSuchProcess:
                continue
        time.sleep(0.1)
    out, err = proc.communicate(timeout=300)
    assert killed is not None, "no simulation was caught running"
    assert proc.returncode == 0, err
    points = CampaignStore(tmp_path / "runs/double.h5").points()
    assert len(points) == 4 + 2 * 2
    assert all(p.status == "done" for p in points), [p.sims for p in points if p.status != "done"]
    for folder in (tmp_path / "runs/double.runs").iterdir():
        completions = (folder / "completions.log").read_text().splitlines()
        assert len(completions) == 1, f"{folder.name} ran to completion {len(completions)} times"


def test_slurm_job_script_from_campaign_yaml(tmp_path):
    executor = {"name": "dask", "cluster": "slurm", "workers": 4, "cores": 8, "memory": "16GB",
                "walltime": "02:30:00", "queue": "compute", "account": "powder-lab",
                "job_extra_directives": ["--exclusive", "--constraint=skylake"]}
    path = write_double_campaign(tmp_path, executor=executor)
    config = load_config(path)
    script = get_manager().create("executor", "dask", **config.executor_options).job_script()
    for line in ("#SBATCH -p compute", "#SBATCH -A powder-lab", "#SBATCH -n 1", "#SBATCH --cpus-per-task=8",
                 "#SBATCH -t 02:30:00", "#SBATCH --exclusive", "#SBATCH --constraint=skylake"):
        assert line in script, script
    assert "#SBATCH --mem=15G" in script  # dask-jobqueue's rounding of 16 GB
    assert "--resources cores=8" in script and "--nthreads 8" in script
    check = calibrax_cli("run", str(path), "--check")
    assert check.returncode == 0 and "#SBATCH -A powder-lab" in check.stdout, check.stderr


def test_dask_executor_options_are_validated(tmp_path):
    cases = [({"name": "dask"}, "give exactly one of 'address'"),
             ({"name": "dask", "cluster": "sge"}, "executor.cluster: must be one of"),
             ({"name": "dask", "cluster": "slurm"}, "executor.memory: is required"),
             ({"name": "dask", "cluster": "local", "job_extra_directives": "--exclusive"}, "must be a list"),
             ({"name": "dask", "address": "localhost:8786"}, "must look like tcp://HOST:PORT")]
    for executor, message in cases:
        path = write_double_campaign(tmp_path, executor=executor)
        proc = calibrax_cli("run", str(path), "--check")
        assert proc.returncode == 2 and message in proc.stderr, (executor, proc.stderr)


def test_gpu_workers_offer_the_gpu_resource_and_a_cuda_simulation_asks_for_one(tmp_path):
    """``gpus`` per worker is offered as the Dask resource GPU; a simulation on
    ``numerics.device: cuda`` asks for one of them beside its cores, a CPU one for none."""
    from calibrax.core.running.dask_executor import _resources
    from calibrax.core.running.executor import SimulationTask
    from calibrax.core.sheartest import ShearCellSpec

    executor = {"name": "dask", "cluster": "slurm", "workers": 2, "cores": 4, "gpus": 1, "memory": "16GB",
                "job_extra_directives": ["--gres=gpu:1"]}
    path = write_double_campaign(tmp_path, executor=executor)
    config = load_config(path)
    script = get_manager().create("executor", "dask", **config.executor_options).job_script()
    assert "--resources cores=4,GPU=1" in script and "#SBATCH --gres=gpu:1" in script, script
    spec = ShearCellSpec.preset("tiny")
    on_gpu = SimulationTask(0, "numba_dem", spec.replace(numerics={"device": "cuda"}), tmp_path)
    on_cpu = SimulationTask(1, "numba_dem", spec, tmp_path)
    assert _resources(on_gpu.threads, on_gpu.gpus) == {"cores": 1, "GPU": 1}
    assert _resources(on_cpu.threads, on_cpu.gpus) == {"cores": 1}
