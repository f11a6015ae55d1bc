"""A campaign through a real single-node SLURM (Debian's slurm-wlm, started by
tests/integration/slurm/start-single-node.sh): dask-jobqueue submits the worker job with sbatch,
the worker connects back, and the campaign runs to the end."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from calibrax import CampaignStore
from tests.conftest import calibrax_cli, double_env, write_double_campaign

START = Path(__file__).parent / "slurm" / "start-single-node.sh"


@pytest.fixture(scope="module")
def slurm():
    proc = subprocess.run(["bash", str(START)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"single-node SLURM did not start:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout.split()[0].rstrip("*")


def test_campaign_through_slurm(tmp_path, slurm):
    executor = {"name": "dask", "cluster": "slurm", "workers": 1, "cores": 2, "memory": "4GB",
                "walltime": "00:15:00", "queue": slurm, "log_directory": str(tmp_path / "slurm-logs")}
    path = write_double_campaign(tmp_path, budget={"initial": 3, "iterations": 1}, executor=executor)
    proc = calibrax_cli("run", str(path), env=double_env(CALIBRAX_DOUBLE_SLEEP="0.5"), timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    points = CampaignStore(tmp_path / "runs/double.h5").points()
    assert len(points) == 5 and all(p.status == "done" for p in points)
    for folder in (tmp_path / "runs/double.runs").iterdir():
        line = (folder / "completions.log").read_text()
        assert "slurm_job=-" not in line, f"{folder.name} did not run inside a SLURM job: {line}"
