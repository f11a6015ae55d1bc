"""benchmarks/calibration_dem.py's bookkeeping (issue 51's DEM-level multi-fidelity benchmark) on
the analytic TEST DOUBLE: a campaign at the target alone and one across a cheap level, the CPU and
simulations per level read from the stores after every batch, the "reached and stays" rule, the
table, and a rerun that repeats no simulation. The real engine's run is the command in the
benchmark's docstring."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import completions_logged

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import calibration_dem as bench  # noqa: E402


def _cp(cpu: float, mu_error: float) -> "bench.Checkpoint":
    return bench.Checkpoint(0, {}, cpu, np.array([0.5, 0.5 + mu_error]), None)


def test_reached_is_the_cpu_from_which_the_error_stays_within_the_tolerance():
    truth = np.array([0.5, 0.5])
    cps = [_cp(100, 0.01), _cp(200, 0.2), _cp(300, 0.04), _cp(400, 0.0)]
    assert bench.cpu_to_reach(cps, truth, 0.05, 70) == (300, True)
    assert bench.cpu_to_reach(cps[:2], truth, 0.05, 70) == (270, False)


def test_the_multi_fidelity_and_the_target_only_campaigns_are_scored_and_resume(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("CALIBRAX_DOUBLE_NOISE", "0.03")  # replicates that scatter, as a real engine's
    argv = ["--simulator", "analytic_double", "--preset", "quick", "--cheap", "tiny", "--strategies", "default,mfei",
            "--targets", "1", "--budget", "6", "--workers", "2", "--out", str(tmp_path)]
    assert bench.main(argv) == 0
    out = capsys.readouterr().out
    rows = {line.split("|")[1].strip(): line for line in out.splitlines() if line.startswith("| default ")
            or line.startswith("| mfei ")}
    assert set(rows) == {"default", "mfei"}
    assert "quick 6" in rows["default"]
    assert "tiny" in rows["mfei"] and "quick" in rows["mfei"]
    assert "mfei's median CPU to the tolerance / default's:" in out
    folder = tmp_path / "target-0"
    done = completions_logged(tmp_path)
    assert done == 3 + 6 + (8 + 3 + 2 * 1)  # replicates, default's 4 + 2, mfei's 8 cheap + 3 target + a batch
    from calibrax import load_config

    config = load_config(folder / "mfei.yaml")
    cps = bench.checkpoints(config, "mfei")
    assert cps[0].simulations == {"tiny": 8, "quick": 3} and cps[-1].simulations["tiny"] + \
        cps[-1].simulations["quick"] == 13
    assert all(b.cpu_s >= a.cpu_s for a, b in zip(cps, cps[1:]))
    assert bench.main(argv) == 0
    assert completions_logged(tmp_path) == done, "a rerun simulated again"


def test_a_cheap_level_that_is_the_target_is_refused(tmp_path, capsys):
    assert bench.main(["--strategies", "mfei", "--preset", "tiny", "--cheap", "tiny", "--out", str(tmp_path)]) == 2
    assert "--cheap tiny is the target itself" in capsys.readouterr().err
