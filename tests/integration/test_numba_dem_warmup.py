"""``make setup`` compiles numba_dem's kernels once (``python -m calibrax_numba_dem.warmup``): a
shear test run after it compiles nothing more, so a fresh machine's first simulations do not each
pay Numba's compilation (issue 21: 113 and 117 s for tests that take 23 s warm)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import ROOT

#: a fresh cache compiles every kernel again (about 70 s): the full tier only; ``make setup`` runs the
#: same warm-up before every tier
pytestmark = [pytest.mark.slow, pytest.mark.numba_dem]

#: a real but very short shear test: the tiny cell with rotations of 0.01 rad
SHORT_TEST = """
import sys, tempfile
from pathlib import Path
from calibrax import ShearCellSpec
from calibrax_numba_dem import NumbaDEMSimulator
spec = ShearCellSpec.preset("tiny").replace(procedure={"preshear_rotation": 0.01, "preshear_max_rotation": None,
                                                      "shear_rotation": 0.01,
                                                      "settle_time": 0.001, "peak_window": 0.005})
with tempfile.TemporaryDirectory() as work:
    result = NumbaDEMSimulator().simulate(spec, Path(work))
assert result.is_finite(), result.peak_shear_stress
"""


def _cached(folder) -> dict[str, float]:
    return {str(p.relative_to(folder)): p.stat().st_mtime for p in folder.rglob("*.nbc")}


def test_after_the_warmup_a_shear_test_compiles_nothing(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    warm = subprocess.run([sys.executable, "-m", "calibrax_numba_dem.warmup"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=1800)
    assert warm.returncode == 0 and "kernels compiled" in warm.stderr, warm.stderr[-3000:]
    before = _cached(tmp_path / "cache")
    assert len(before) >= 10, sorted(before)  # the engine's, the neighbour lists' and the servo's kernels
    run = subprocess.run([sys.executable, "-c", SHORT_TEST], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=1800)
    assert run.returncode == 0, run.stderr[-3000:]
    assert _cached(tmp_path / "cache") == before, "the shear test compiled kernels the warm-up had not"
