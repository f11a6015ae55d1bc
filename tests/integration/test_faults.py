"""Faults are data: crashes, hangs past the timeout and NaN results are recorded with their reason
while the campaign goes on; a failed point is never proposed again; SIGTERM stops cleanly and a
rerun repeats nothing. (Core tests: the analytic TEST DOUBLE plays the backend.)"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import psutil
import pytest

from calibrax import CampaignStore, load_config, run_campaign
from calibrax.core.search.points import DUPLICATE_TOL
from tests.conftest import ROOT, double_env, write_double_campaign


@pytest.mark.parametrize("fault, kind, reason", [
    ("crash", "crash", "simulation process died (signal 6)"),
    ("hang", "timeout", "timed out after 10 s"),
    ("nan", "nan", "non-finite peaks"),
])
def test_fault_is_recorded_and_campaign_goes_on(tmp_path, monkeypatch, fault, kind, reason):
    monkeypatch.setenv("CALIBRAX_DOUBLE_FAULT", f"{fault}:0.6")
    # a healthy double takes well under a second, but the session's simulation bank keeps both cores
    # busy meanwhile (tests/bank.py): the timeout leaves room for a slow start
    config = load_config(write_double_campaign(tmp_path, budget={"initial": 6, "iterations": 2},
                                               executor={"name": "local", "workers": 2, "timeout_s": 10.0}))
    summary = run_campaign(config)
    points = CampaignStore(config.store).points()
    assert summary.points == 6 + 2 * 2, "the campaign ran its whole budget"
    failed = [p for p in points if p.status == "failed"]
    assert failed and summary.failed == len(failed)
    for p in failed:
        assert p.params()["sliding_friction"] > 0.6
        sim = p.sims[0]
        assert sim.kind == kind and reason in sim.reason
    assert all(p.status == "done" for p in points if p.params()["sliding_friction"] <= 0.6)
    # no simulation process outlives the campaign
    assert not [c for c in psutil.Process().children(recursive=True) if "calibrax.core.running.isolate" in " ".join(c.cmdline())]


def test_failed_points_are_penalised_and_never_proposed_again(tmp_path, monkeypatch):
    # The truth (μs = 0.45) lies beside a region that fails (μs > 0.5): EI is drawn there.
    monkeypatch.setenv("CALIBRAX_DOUBLE_FAULT", "fail:0.5")
    config = load_config(write_double_campaign(tmp_path, budget={"initial": 6, "iterations": 6}))
    run_campaign(config)
    store = CampaignStore(config.store)
    points = store.points()
    failed = [p for p in points if p.status == "failed"]
    assert failed
    for p in points:  # a repeat of a finished point may run as a replicate; a crash is never repeated
        crashes = [f.unit for f in failed if f.id < p.id]
        if crashes:
            gaps = np.max(np.abs(np.stack(crashes) - p.unit), axis=1)
            assert gaps.min() >= DUPLICATE_TOL, f"point {p.id} repeats a crash"
    models = store.models()
    first_failure_batch = min(p.batch for p in failed)
    assert any(m["penalised_failures"] > 0 for b, m in models.items() if b > first_failure_batch)
    assert sum(p.status == "done" for p in points if p.batch > 0) >= 6, "the search mostly avoids the failing region"


def test_sigterm_stops_cleanly_and_rerun_repeats_nothing(tmp_path):
    path = write_double_campaign(tmp_path, budget={"initial": 4, "iterations": 3})
    env = double_env(CALIBRAX_DOUBLE_SLEEP="1.5")
    store_path = tmp_path / "runs/double.h5"
    proc = subprocess.Popen([sys.executable, "-m", "calibrax.cli", "run", str(path)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if store_path.exists() and sum(p.status == "done" for p in CampaignStore(store_path).points()) >= 2:
            break
        time.sleep(0.2)
    children = psutil.Process(proc.pid).children(recursive=True)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "run the same command again to resume" in err
    gone, alive = psutil.wait_procs(children, timeout=10)
    assert not alive, "running simulations were not cancelled"
    before = {(p.id, s.index): s.seed for p in CampaignStore(store_path).points() for s in p.sims if s.status == "done"}
    stamps = {k: CampaignStore(store_path).result(*k).provenance.wall_time for k in before}
    assert len(before) >= 2
    status = subprocess.run([sys.executable, "-m", "calibrax.cli", "status", str(store_path)], cwd=ROOT, env=env,
                            capture_output=True, text=True, timeout=120)
    assert " interrupted" in status.stdout and "run again" in status.stdout, status.stdout  # not "pending"
    again = subprocess.run([sys.executable, "-m", "calibrax.cli", "run", str(path)], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    points = CampaignStore(store_path).points()
    assert len(points) == 4 + 3 * 2 and all(p.status == "done" for p in points)
    for key, stamp in stamps.items():
        assert CampaignStore(store_path).result(*key).provenance.wall_time == stamp, f"{key} was re-run"
    for key in before:
        assert f"point {key[0]} sim {key[1]}: analytic_double starts" not in again.stderr
    for folder in (tmp_path / "runs/double.runs").iterdir():
        assert len((folder / "completions.log").read_text().splitlines()) == 1, f"{folder.name} completed twice"
