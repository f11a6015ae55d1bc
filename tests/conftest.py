"""Shared fixtures: the analytic TEST DOUBLE campaign set-up (core tests only), the session's bank of
real-engine shear tests (tests/bank.py), and the test tiers.

The tiers (docs/how-to/run-the-tests.md):

- ``pytest --tier fast`` (``make test``): every test not marked ``slow``; each of the three engines
  still runs a whole shear test (the bank's smoke tests), and the session fails if one of them did
  not finish a real shear test, whatever else passed.
- ``pytest --tier all`` (``make test-all``): everything, with the same check.
- a bare ``pytest`` runs what it is given, with no check.

Markers: ``slow`` (the full tier only), ``numba_dem``, ``liggghts``, ``yade`` (a test of that
backend; ``pytest -m yade`` runs every YADE test), ``bank(NAME, ...)`` (reads these bank jobs).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _default_numba_cache() -> str:
    """``.numba_cache/<key of numba_dem's sources>``, the folder ``make`` gives NUMBA_CACHE_DIR, so
    that a bare ``pytest`` uses the kernels ``make setup`` compiled (and never stale ones)."""
    path = ROOT / "plugins/numba_dem/src/calibrax_numba_dem/cache_key.py"
    spec = importlib.util.spec_from_file_location("_numba_dem_cache_key", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return str(ROOT / ".numba_cache" / module.cache_key())


# All set before Numba is imported (and inherited by the simulations' processes).
os.environ.setdefault("NUMBA_CACHE_DIR", _default_numba_cache())
# The thread-count determinism test of numba_dem compares 1 and 2 threads; Numba caps its threads
# at NUMBA_NUM_THREADS (the core count by default), so a 1-core machine gets 2 here.
if (os.cpu_count() or 1) < 2:
    os.environ.setdefault("NUMBA_NUM_THREADS", "2")
# Numba's OpenMP threads spin while they wait for work; beside the suite's other processes on 2
# cores that made a 13 s in-process pour take 128 s (measured with two busy processes beside it)
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# numba_dem's CUDA path runs under Numba's CUDA simulator here (CI has no GPU): its kernels run on
# the CPU thread by thread (tests/integration/test_numba_dem_cuda.py). On a GPU, its own check is
# benchmarks/gpu_check.py, which sets NUMBA_ENABLE_CUDASIM=0.
os.environ.setdefault("NUMBA_ENABLE_CUDASIM", "1")

import numpy as np
import pytest
import yaml

from tests.bank import JOBS, SMOKE_NUMERICS, SMOKE_PROCEDURE, SimulationBank, read_engine_runs

#: the test doubles, registered through CALIBRAX_PLUGINS as a third party would register a plugin
DOUBLE_MODULE = "tests.doubles.analytic_simulator,tests.doubles.thirdparty_plugin"
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


def write_double_experiment(path: Path, e: float = TRUE_E, mu: float = TRUE_MU,
                            particles_per_diameter: float = 9.0) -> Path:
    """A pseudo-experiment made by the analytic double at (e, mu) in a cell of
    ``particles_per_diameter`` (default ``tiny``'s), three replicates with a small known scatter;
    the header says so."""
    from tests.doubles.analytic_simulator import fidelity_bias, true_locus

    c, aif = true_locus(e, mu)
    bias_c, bias_slope = fidelity_bias(particles_per_diameter)
    c, slope = c + bias_c, np.tan(np.radians(aif)) + bias_slope
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


def completions_logged(folder: Path) -> int:
    """Simulations the analytic double completed under ``folder`` (its ``completions.log`` lines)."""
    return sum(len(p.read_text().splitlines()) for p in folder.rglob("completions.log"))


def run_hidden_effect_campaign(folder: Path, spec: ShearCellSpec, noise: dict[str, str], **changes) -> Path:
    """Make a double pseudo-experiment of ``spec`` (3 replicates, a hidden effect set in it) in
    ``folder``, run a ``robust`` campaign against it on the command line (``changes`` update the
    config's keys) and return its store, ``folder/walled.h5``."""
    from calibrax.core.data.pseudo import write_pseudo_experiment

    saved = {k: os.environ.get(k) for k in noise}
    os.environ.update(noise)
    try:
        write_pseudo_experiment(spec, "analytic_double", folder / "walled", 3)
    finally:
        for k, v in saved.items():
            os.environ.pop(k) if v is None else os.environ.__setitem__(k, v)
    config = {"name": "walled", "simulator": "analytic_double", "experiment": "walled.yaml", "cell": {"preset": "tiny"},
              "parameters": {"youngs_modulus": {"low": 5e9, "high": 5e10, "log": True},
                             "sliding_friction": {"low": 0.1, "high": 0.9}},
              "metric": "robust", "acquisition": {"name": "qei", "q": 2}, "budget": {"initial": 4, "iterations": 1},
              "executor": {"name": "local", "workers": 2}, "store": "walled.h5", "seed": 1, **changes}
    cfg = folder / "campaign.yaml"
    cfg.write_text(yaml.safe_dump(config))
    run = calibrax_cli("run", str(cfg), "-q", env=double_env(**noise))
    assert run.returncode == 0, run.stderr
    return folder / "walled.h5"


def calibrax_cli(*args: str, env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run the real ``calibrax`` command line in a subprocess."""
    return subprocess.run([sys.executable, "-m", "calibrax.cli", *args], capture_output=True, text=True,
                          env=env or double_env(), timeout=timeout, cwd=ROOT)


PSEUDO_EXPERIMENT = ROOT / "examples/data/pseudo-numba-tiny-points.csv"
#: The bank's smoke test (tests/bank.py) as a campaign's ``cell``: the whole procedure at rotations
#: of 0.02 rad, about 6 s per simulation on numba_dem; E comes from the campaign's parameters.
SMOKE_CELL = {"preset": "tiny", "procedure": {"preset": "paper", **SMOKE_PROCEDURE}, "numerics": dict(SMOKE_NUMERICS)}


def write_backend_campaign(folder: Path, simulator: str, **changes) -> Path:
    """A short campaign on a REAL backend against the bundled pseudo-experiment, on the smoke
    test's cell (:data:`SMOKE_CELL`) with E of 1–2 GPa (the smoke test's 1 GPa and a little
    stiffer); ``changes`` update its keys. The timeout is only a safety net: the session's
    simulation bank (tests/bank.py) runs beside these campaigns, so a simulation may take several
    times its time on an idle machine."""
    import shutil

    shutil.copy(PSEUDO_EXPERIMENT, folder / "exp.csv")
    config = {
        "name": f"{simulator}-campaign",
        "simulator": simulator,
        "experiment": "exp.csv",
        "cell": SMOKE_CELL,
        "parameters": {"youngs_modulus": {"low": 1.0e9, "high": 2.0e9, "log": True},
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


# ----------------------------------------------------------------------------- test tiers
#: the engines every tier must see finish a real shear test
ENGINES = ("numba_dem", "liggghts", "yade")
TIERS = {"fast": "not slow", "all": None}
#: the session folder (bank outcomes, engine-run records), made by the first process and inherited
#: by xdist's workers
SESSION_VARIABLE = "CALIBRAX_TEST_SESSION"
_BANK = pytest.StashKey[SimulationBank]()


def pytest_addoption(parser) -> None:
    parser.addoption("--tier", choices=sorted(TIERS), default=None,
                     help="fast: every test not marked slow (make test); all: everything (make test-all). "
                          "Either fails the session if one of the engines numba_dem, liggghts, yade did not "
                          "finish a real shear test.")


def _xdist_worker(config) -> bool:
    return hasattr(config, "workerinput")


def pytest_configure(config) -> None:
    tier = config.getoption("--tier")
    if tier is not None and TIERS[tier]:
        if config.option.markexpr:
            raise pytest.UsageError(f"--tier {tier} selects with -m {TIERS[tier]!r} itself; give -m without --tier")
        config.option.markexpr = TIERS[tier]
    if not _xdist_worker(config):  # a new folder, also in a pytest run by a test of this suite
        os.environ[SESSION_VARIABLE] = tempfile.mkdtemp(prefix="calibrax-tests-")


def bank_jobs(item) -> list[str]:
    """The bank jobs a test names with ``@pytest.mark.bank(...)`` (its own and its module's)."""
    return [name for mark in item.iter_markers("bank") for name in mark.args]


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items) -> None:
    """Mark each test that reads bank jobs with their engines (before ``-m`` selects by them), and
    run those tests last (the bank runs beside everything else meanwhile)."""
    for item in items:
        names = bank_jobs(item)
        unknown = [n for n in names if n not in JOBS]
        if unknown:
            raise pytest.UsageError(f"{item.nodeid} names bank job(s) {unknown} that no module declared")
        for backend in sorted({JOBS[n].backend for n in names}):
            item.add_marker(backend)
    items.sort(key=lambda item: bool(bank_jobs(item)))


def pytest_collection_finish(session) -> None:
    """Start the bank with the jobs of the selected tests (what ``-m``, ``-k`` and the paths left),
    unless another process of this session already has."""
    if session.config.option.collectonly:
        return
    selected = {name for item in session.items for name in bank_jobs(item)}
    bank = SimulationBank(Path(os.environ[SESSION_VARIABLE]), selected)
    session.config.stash[_BANK] = bank
    bank.start()


@pytest.fixture(scope="session")
def bank(request) -> SimulationBank:
    """The session's :class:`tests.bank.SimulationBank` of real-engine shear tests."""
    return request.config.stash[_BANK]


@pytest.hookimpl(trylast=True)
def pytest_sessionfinish(session, exitstatus) -> None:
    """The bank's owner waits for its jobs (another process may read them); under ``--tier`` the
    session fails if an engine did not finish a real shear test in it."""
    config = session.config
    if _BANK in config.stash:
        config.stash[_BANK].close(wait=exitstatus != pytest.ExitCode.INTERRUPTED)
    if _xdist_worker(config):
        return
    folder = Path(os.environ[SESSION_VARIABLE])
    if config.getoption("--tier") is not None and not config.option.collectonly:
        _check_every_engine_ran(session, folder, exitstatus)
    if session.exitstatus == pytest.ExitCode.OK:
        shutil.rmtree(folder, ignore_errors=True)
    elif (folder / "bank").is_dir() and any((folder / "bank").iterdir()):
        print(f"\nthe simulation bank's work folders are kept in {folder / 'bank'}", file=sys.stderr)


def _check_every_engine_ran(session, folder: Path, exitstatus: int) -> None:
    """Fail the session if one of :data:`ENGINES` did not finish a real shear test in it."""
    config = session.config
    runs = read_engine_runs(folder)
    missing = [e for e in ENGINES if not any(r["backend"] == e and r["wall_time"] > 0 for r in runs)]
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    write = reporter.write_line if reporter is not None else print
    if reporter is not None:
        reporter.write_line("")  # after the progress line
        reporter.write_sep("-", "real engine runs in this session")
    for engine in ENGINES:
        times = [r["wall_time"] for r in runs if r["backend"] == engine]
        write(f"{engine}: {len(times)} shear test(s), {sum(times):.0f} s of engine wall time")
    if missing and exitstatus in (pytest.ExitCode.OK, pytest.ExitCode.TESTS_FAILED):
        write(f"ERROR: the {config.getoption('--tier')} tier finished no real shear test on {', '.join(missing)}: "
              "every tier must run each engine (the smoke tests of tests/bank.py; docs/how-to/run-the-tests.md)")
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
