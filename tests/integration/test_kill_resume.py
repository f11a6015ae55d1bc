"""SIGKILL a running campaign at many moments — during simulations and in the middle of a store
write — then resume: no finished result is lost, none is repeated, and the store always opens."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import h5py

from calibrax import CampaignStore
from tests.conftest import ROOT, double_env, write_double_campaign


def finished(store_path) -> dict[tuple[int, int], float]:
    """{(point, sim): finished_at} of every finished simulation; also proves the store opens."""
    out = {}
    with h5py.File(store_path, "r") as f:
        for key, g in f["points"].items():
            for name, s in g.items():
                if name.startswith("sim"):
                    out[(int(key[1:]), int(name[3:]))] = float(s.attrs["finished_at"])
    return out


def start(path, env):
    return subprocess.Popen([sys.executable, "-m", "calibrax.cli", "run", str(path)], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def test_sigkill_at_many_moments_then_resume(tmp_path):
    path = write_double_campaign(tmp_path, budget={"initial": 4, "iterations": 4})
    store_path = tmp_path / "runs/double.h5"
    tmp_file = store_path.with_name(store_path.name + ".tmp")
    env = double_env(CALIBRAX_DOUBLE_SLEEP="0.4")
    seen: dict[tuple[int, int], float] = {}
    kills, mid_write = 0, 0
    delays = [1.5, 4.0, 6.0, None, None, 5.0, None, 8.0]  # None: kill as soon as a store write is under way
    for delay in delays:
        proc = start(path, env)
        t0 = time.monotonic()
        while proc.poll() is None:
            if delay is None and tmp_file.exists():
                break
            if delay is not None and time.monotonic() - t0 >= delay:
                break
            if time.monotonic() - t0 > 120:
                break
        if proc.poll() is None:
            was_writing = tmp_file.exists()
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait()
            kills += 1
            mid_write += was_writing and tmp_file.exists()
        if store_path.exists():
            now = finished(store_path)
            for key, stamp in seen.items():
                assert now.get(key) == stamp, f"finished simulation {key} was lost or repeated"
            seen = now
    final = start(path, env)
    _, err = final.communicate(timeout=600)
    assert final.returncode == 0, err
    now = finished(store_path)
    for key, stamp in seen.items():
        assert now[key] == stamp, f"finished simulation {key} was repeated after resume"
    points = CampaignStore(store_path).points()
    assert len(points) == 4 + 4 * 2
    assert all(p.status == "done" for p in points)
    assert not tmp_file.exists()
    assert kills >= 5
    assert mid_write >= 1, "no kill landed during a store write; the test did not test that"
