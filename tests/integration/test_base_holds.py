"""The default base holds the bed on the real engines: τ is the powder's, not the base's.

With the default base (one-diameter ribs, as many as the head's blades) the steady τ/σ at the end
of the shear windows must not depend on the base's own friction (0.5 against 1.0 agree within
their seed spread), no base-slip warning may fire from μs = 0.1 to 0.9, and the slip measure must
see a base that does *not* hold (a flat base, and ribs a tenth of a diameter high on a
frictionless base). ``tiny`` cells, from the session's simulation bank (tests/bank.py). numba_dem blew up in exactly these
cases (μ_b = 1, μs = 0.9) at the former 0.20 Δt_crit, and LIGGGHTS lost atoms: they also guard the
presets' time step.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from calibrax import ShearCellSpec
from calibrax.core.data.features import result_features, step_mean
from calibrax.core.sheartest import BASE_SPIN_SLIP_FRACTION
from tests.bank import declare_short, declare_tiny

#: seeds per base friction: three on numba_dem; two on LIGGGHTS, whose tiny test takes about twice
#: as long (quick, three seeds each: docs/explanation/shear-test.md, "What holds the bed")
SEEDS = {"numba_dem": (0, 1, 2), "liggghts": (0, 1)}
BACKENDS = tuple(SEEDS)


def _declare_cases(backend: str) -> dict[tuple[str, int], str]:
    """The bank jobs of one backend, by (case, seed); the preset's own seed 0 and the short μs
    cases are shared with the backends' shear-test modules."""
    jobs = {}
    for seed in SEEDS[backend]:
        jobs[("mu_base_0.5", seed)] = declare_tiny(backend, seed)
        jobs[("mu_base_1.0", seed)] = declare_tiny(backend, seed, "tiny-base1", geometry={"base_friction": 1.0})
    # slip alone needs no steady state: half the rotations
    jobs[("mu_s_0.1", 0)] = declare_short(backend, "mu_s_0.1", material={"sliding_friction": 0.1})
    jobs[("mu_s_0.9", 0)] = declare_short(backend, "mu_s_0.9", material={"sliding_friction": 0.9})
    jobs[("flat", 0)] = declare_short(backend, "flat", geometry={"base_ribs": 0})
    if backend == "numba_dem":  # issue 22: ribs a tenth of a diameter high on a frictionless base
        radius = ShearCellSpec.preset("tiny").radius
        jobs[("weak_ribs", 0)] = declare_short(backend, "weak_ribs", geometry={
            "rib_height": 0.1 * 2 * radius, "base_friction": 0.0, "base_rolling_friction": 0.0})
    return jobs


JOBS = {backend: _declare_cases(backend) for backend in BACKENDS}
pytestmark = [pytest.mark.slow, pytest.mark.bank(*(name for jobs in JOBS.values() for name in jobs.values()))]


@pytest.fixture(scope="module", params=BACKENDS)
def runs(request, bank):
    backend = request.param
    return backend, {key: bank.result(name) for key, name in JOBS[backend].items()}


def _steady_ratio(result) -> float:
    """Mean steady τ/σ at the end of the four shear windows."""
    return step_mean(result_features(result), "shear_end_ratio")


def test_the_steady_ratio_does_not_depend_on_the_bases_friction(runs):
    backend, results = runs
    low = np.asarray([_steady_ratio(results[("mu_base_0.5", s)]) for s in SEEDS[backend]])
    high = np.asarray([_steady_ratio(results[("mu_base_1.0", s)]) for s in SEEDS[backend]])
    # two standard errors of the difference of the means, from the seeds' own spread
    limit = 2.0 * math.sqrt(low.var(ddof=1) / low.size + high.var(ddof=1) / high.size)
    assert abs(low.mean() - high.mean()) <= limit, (backend, low, high, limit)


@pytest.mark.parametrize("case", [("mu_s_0.1", 0), ("mu_base_0.5", 0), ("mu_s_0.9", 0)])
def test_no_base_slip_from_low_to_high_friction(runs, case):
    backend, results = runs
    result = results[case]
    assert not any("slid on the base" in w for w in result.warnings), (backend, case, result.warnings)
    assert np.all(result.base_slip < BASE_SPIN_SLIP_FRACTION), (backend, case, result.base_slip)


def test_a_base_that_does_not_hold_is_seen_slipping(runs):
    backend, results = runs
    cases = [c for c in (("flat", 0), ("weak_ribs", 0)) if c in results]
    assert ("flat", 0) in cases
    for case in cases:
        result = results[case]
        assert np.nanmax(result.base_slip) >= BASE_SPIN_SLIP_FRACTION, (backend, case, result.base_slip)
        assert any("slid on the base" in w for w in result.warnings), (backend, case, result.warnings)
