"""The test tiers themselves (tests/conftest.py): a tier that runs no real engine fails, whatever
else passes; the fast tier leaves the slow tests out; engines are markers. Each case runs pytest
on a small selection of this suite in a subprocess, without xdist."""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import ROOT


def _pytest(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider", *args],
                          cwd=ROOT, capture_output=True, text=True, timeout=600, check=False)


def test_a_tier_that_runs_no_engine_fails_although_its_tests_pass():
    proc = _pytest("--tier", "fast", "tests/unit/test_parameters.py")
    assert "passed" in proc.stdout and "failed" not in proc.stdout, proc.stdout[-2000:]
    assert proc.returncode == 1, proc.stdout[-2000:]
    assert "finished no real shear test on numba_dem, liggghts, yade" in proc.stdout, proc.stdout[-2000:]
    for engine in ("numba_dem", "liggghts", "yade"):
        assert f"{engine}: 0 shear test(s)" in proc.stdout


def test_the_fast_tier_leaves_slow_tests_out_and_engines_are_markers():
    """``--tier fast`` is ``-m 'not slow'`` (a ``-m`` beside it is refused); a test that reads a
    bank job carries its engine's marker, so ``-m liggghts`` selects it."""
    fast = _pytest("--tier", "fast", "--collect-only", "tests/integration/test_yade_sheartest.py")
    assert fast.returncode == 0, fast.stdout[-2000:]
    assert "test_four_finite_peaks" in fast.stdout and "test_frictionless_vessel" not in fast.stdout
    both = _pytest("--tier", "fast", "-m", "yade", "--collect-only", "tests/integration/test_yade_sheartest.py")
    assert both.returncode != 0 and "give -m without --tier" in both.stdout + both.stderr
    by_engine = _pytest("-m", "liggghts", "--collect-only", "tests/integration/test_diagnose_benchmark.py")
    names = [line for line in by_engine.stdout.splitlines() if "::" in line]
    expected = "tests/integration/test_diagnose_benchmark.py::test_blinded_files_read_back_and_tell_nothing"
    assert names == [expected + "[liggghts/smoke/s0]"], by_engine.stdout[-2000:]
