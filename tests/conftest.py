"""Shared fixtures: the analytic TEST DOUBLE campaign set-up (core tests only)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

# The thread-count determinism test of numba_dem compares 1 and 2 threads; Numba caps its threads
# at NUMBA_NUM_THREADS (the core count by default), so a 1-core machine gets 2 here (set before Numba
# is imported).
if (os.cpu_count() or 1) < 2:
    os.environ.setdefault("NUMBA_NUM_THREADS", "2")

import numpy as np  # noqa: E402
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOUBLE_MODULE = "tests.doubles.analytic_simulator"
TRUE_E, TRUE_MU = 2.0e10, 0.45


def double_env(**extra: str) -> dict[str, str]:
    """Environment for a subprocess that sees the analytic test double."""
    env = dict(os.environ)
    env["CALIBRAX_PLUGINS"] = DOUBLE_MODULE
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env.update(extra)
    return env


@pytest.fixture(autouse=True, scope="session")
def _register_double() -> None:
    """Let in-process tests see the double too (the manager reads CALIBRAX_PLUGINS once)."""
    os.environ["CALIBRAX_PLUGINS"] = DOUBLE_MODULE
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)


def write_double_experiment(path: Path, e: float = TRUE_E, mu: float = TRUE_MU) -> Path:
    """A pseudo-experiment made by the analytic double at (e, mu), three replicates with a small
    known scatter; the header says so."""
    from tests.doubles.analytic_simulator import true_locus

    c, aif = true_locus(e, mu)
    slope = np.tan(np.radians(aif))
    offsets = {1: (0.0, 0.0), 2: (40.0, 0.012), 3: (-40.0, -0.012)}
    lines = [f"# pseudo-experiment from the analytic TEST DOUBLE at E = {e:g} Pa, mu_s = {mu:g}",
             "normal_stress_pa,peak_shear_stress_pa,replicate"]
    for rep, (dc, ds) in offsets.items():
        for sigma in (9000.0, 8000.0, 7000.0, 6000.0):
            lines.append(f"{sigma:.0f},{c + dc + sigma * (slope + ds):.3f},{rep}")
    path.write_text("\n".join(lines) + "\n")
    return path


def write_double_campaign(folder: Path, **changes) -> Path:
    """A campaign file for the analytic double in ``folder``; ``changes`` update its keys."""
    write_double_experiment(folder / "exp.csv")
    config = {
        "name": "double",
        "simulator": "analytic_double",
        "experiment": "exp.csv",
        "cell": {"preset": "tiny"},
        "parameters": {"youngs_modulus": {"low": 5.0e9, "high": 5.0e10, "log": True},
                       "sliding_friction": {"low": 0.1, "high": 0.9}},
        "metric": "c_aif",
        "acquisition": {"name": "qei", "q": 2},
        "budget": {"initial": 4, "iterations": 6},
        "executor": {"name": "local", "workers": 2},
        "store": "runs/double.h5",
        "seed": 3,
    }
    config.update(changes)
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    return path


def calibrax_cli(*args: str, env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run the real ``calibrax`` command line in a subprocess."""
    return subprocess.run([sys.executable, "-m", "calibrax.cli", *args], capture_output=True, text=True,
                          env=env or double_env(), timeout=timeout, cwd=ROOT)


PSEUDO_EXPERIMENT = ROOT / "examples/data/pseudo-numba-tiny-points.csv"
#: A shortened ``tiny`` shear test for campaign tests of the real backends: the paper's four
#: steps, half the preset's rotations, so that one simulation takes about a minute on one core.
SHORT_TINY_CELL = {"preset": "tiny", "procedure": {"preset": "paper", "preshear_rotation": 0.06,
                                                   "shear_rotation": 0.06},
                   "numerics": {"dt_fraction": 0.2, "threads": 1}}


def write_backend_campaign(folder: Path, simulator: str, **changes) -> Path:
    """A short campaign on a REAL backend against the bundled pseudo-experiment; ``changes``
    update its keys. E is kept low (5–10 GPa: larger time steps) so that simulations are cheap. The
    timeout is only a safety net: the session's simulation bank (tests/bank.py) runs beside these
    campaigns, so a simulation may take several times its time on an idle machine."""
    import shutil

    shutil.copy(PSEUDO_EXPERIMENT, folder / "exp.csv")
    config = {
        "name": f"{simulator}-campaign",
        "simulator": simulator,
        "experiment": "exp.csv",
        "cell": SHORT_TINY_CELL,
        "parameters": {"youngs_modulus": {"low": 5.0e9, "high": 1.0e10, "log": True},
                       "sliding_friction": {"low": 0.2, "high": 0.6}},
        "metric": "c_aif",
        "acquisition": {"name": "qei", "q": 2},
        "budget": {"initial": 2, "iterations": 1},
        "executor": {"name": "local", "workers": 2, "timeout_s": 3000},
        "store": "runs/campaign.h5",
        "seed": 5,
    }
    config.update(changes)
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    return path


# ----------------------------------------------------------------------------- simulation bank
@pytest.fixture(scope="session")
def bank(tmp_path_factory):
    """The session's :class:`tests.bank.SimulationBank` of real-engine shear tests (started by
    ``_start_bank`` as soon as the session starts)."""
    from tests.bank import SimulationBank

    simulations = SimulationBank(tmp_path_factory.mktemp("bank"))
    yield simulations
    simulations.close()


@pytest.fixture(autouse=True, scope="session")
def _start_bank(request) -> None:
    """Start the declared simulations at the first test, so that they run beside everything else;
    the tests that read them run last (``pytest_collection_modifyitems``)."""
    from tests.bank import JOBS

    if JOBS and any("bank" in item.fixturenames for item in request.session.items):
        request.getfixturevalue("bank").start()


def pytest_collection_modifyitems(config, items) -> None:
    """Tests that read the simulation bank run after all the others (stable order otherwise)."""
    items.sort(key=lambda item: "bank" in getattr(item, "fixturenames", ()))
