"""``calibrax run`` end to end on the real LIGGGHTS and YADE engines (full tier): a campaign on the
smoke test's cell (tests/bank.py: the whole procedure at rotations of 0.02 rad, E of 1–2 GPa)
against the bundled pseudo-experiment runs to the end, resumes as finished, and ``status`` reads
it. LIGGGHTS runs 2 Sobol points and one qEI batch of 2; YADE, about four times slower, runs the 2
Sobol points only (the search itself is engine-independent and is tested on numba_dem through Dask
in test_dask.py and by ``make run``)."""

from __future__ import annotations

import math
import os
import shutil

import pytest

from calibrax import CampaignStore
from tests.conftest import calibrax_cli, write_backend_campaign

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("simulator, iterations", [pytest.param("liggghts", 1, marks=pytest.mark.liggghts),
                                                   pytest.param("yade", 0, marks=pytest.mark.yade)])
def test_campaign_runs_to_the_end_on_the_real_engine(tmp_path, simulator, iterations):
    assert shutil.which(simulator), f"{simulator} is not installed: apt-get install -y {simulator}"
    path = write_backend_campaign(tmp_path, simulator, budget={"initial": 2, "iterations": iterations})
    total = 2 + 2 * iterations
    env = dict(os.environ)
    proc = calibrax_cli("run", str(path), env=env, timeout=3600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    points = CampaignStore(tmp_path / "runs/campaign.h5").points()
    assert len(points) == total
    assert [p.acquisition for p in points].count("qei") == 2 * iterations
    assert all(p.status == "done" and math.isfinite(p.metric.value) for p in points), \
        [(p.id, [s.status for s in p.sims]) for p in points]
    assert f"{simulator}" in proc.stderr and "seed" in proc.stderr
    again = calibrax_cli("run", str(path), env=env, timeout=120)
    assert again.returncode == 0 and "campaign complete" in again.stderr and f"{total} done" in again.stdout, again.stdout
    assert len(CampaignStore(tmp_path / "runs/campaign.h5").points()) == total  # nothing re-run or added
    status = calibrax_cli("status", str(tmp_path / "runs/campaign.h5"), env=env)
    assert status.returncode == 0 and "best" in status.stdout.lower(), status.stdout
