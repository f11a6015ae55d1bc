"""The yield-locus fit and the FT4 Mohr-circle values, against scipy and hand computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from calibrax import YieldLocus
from calibrax.errors import ConfigError


def test_fit_matches_linregress_with_standard_errors():
    sigma = np.array([9000.0, 8000.0, 7000.0, 6000.0])
    tau = np.array([5230.0, 4790.0, 4260.0, 3810.0])
    locus = YieldLocus.fit(sigma, tau)
    ref = stats.linregress(sigma, tau)
    assert locus.cohesion == pytest.approx(ref.intercept, rel=1e-12)
    assert locus.slope == pytest.approx(ref.slope, rel=1e-12)
    assert locus.cohesion_stderr == pytest.approx(ref.intercept_stderr, rel=1e-10)
    assert locus.aif_deg == pytest.approx(math.degrees(math.atan(ref.slope)), rel=1e-12)
    # delta method: d atan(s) = ds / (1 + s²)
    assert locus.aif_stderr_deg == pytest.approx(math.degrees(ref.stderr / (1 + ref.slope**2)), rel=1e-10)
    assert locus.r_squared == pytest.approx(ref.rvalue**2, rel=1e-10)


def test_exact_line_has_zero_errors_and_two_points_have_none():
    sigma = np.array([6000.0, 7000.0, 8000.0, 9000.0])
    locus = YieldLocus.fit(sigma, 500.0 + 0.5 * sigma)
    assert locus.cohesion == pytest.approx(500.0) and locus.aif_deg == pytest.approx(math.degrees(math.atan(0.5)))
    assert locus.cohesion_stderr == pytest.approx(0.0, abs=1e-6)
    two = YieldLocus.fit(sigma[:2], 500.0 + 0.5 * sigma[:2])
    assert math.isnan(two.cohesion_stderr)


def test_degenerate_input_is_refused():
    with pytest.raises(ConfigError, match="distinct"):
        YieldLocus.fit([6000.0, 6000.0], [1.0, 2.0])
    with pytest.raises(ConfigError, match="finite"):
        YieldLocus.fit([6000.0, 7000.0, float("nan")], [1.0, 2.0, 3.0])


def test_mohr_analysis_by_hand():
    # Cohesionless locus at 30°: UYS = 0, FFC infinite; MPS circle tangent to the locus through
    # (σp, τ on locus): hand solution of the quadratic.
    t = math.tan(math.radians(30.0))
    sigma = np.array([6000.0, 9000.0])
    free = YieldLocus.fit(sigma, sigma * t)
    m = free.mohr(15000.0)
    assert m.unconfined_yield_strength == pytest.approx(0.0, abs=1e-9)
    assert math.isinf(m.flow_function)
    # For c = 0 the MPS circle's centre s satisfies r = s sin φ and (σp − s)² + τp² = r².
    phi = math.radians(30.0)
    sp, tp = 15000.0, 15000.0 * t
    a, b, k = math.cos(phi) ** 2, -2 * sp, sp**2 + tp**2
    s = (-b + math.sqrt(max(0.0, b * b - 4 * a * k))) / (2 * a)  # point on the locus: disc = 0
    assert s == pytest.approx(sp / math.cos(phi) ** 2, rel=1e-6)
    assert m.major_principal_stress == pytest.approx(s * (1 + math.sin(phi)), rel=1e-9)
    assert m.effective_angle_deg == pytest.approx(30.0, rel=1e-9)  # δ = φ when c = 0
    # Cohesive locus: UYS = 2c cos φ / (1 − sin φ).
    coh = YieldLocus.fit(sigma, 1000.0 + sigma * t)
    mc = coh.mohr(15000.0)
    assert mc.unconfined_yield_strength == pytest.approx(2000.0 * math.cos(phi) / (1 - math.sin(phi)), rel=1e-9)
    assert mc.flow_function == pytest.approx(mc.major_principal_stress / mc.unconfined_yield_strength)
    assert mc.effective_angle_deg > 30.0
