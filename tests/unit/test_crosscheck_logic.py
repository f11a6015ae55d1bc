"""The cross-check's micro-level agreement rule and the converge option names (no simulator)."""

from __future__ import annotations

import numpy as np
import pytest

from calibrax.core.sheartest import Provenance, ShearCellSpec, ShearTestResult, StepRecord
from calibrax.core.studies.study import shear_window_diagnostics

from calibrax.core.studies.convergence import DENSITY_TOLERANCE, KNOBS, OPTIONS, within_finest
from calibrax.core.studies.crosscheck import MICRO_TOLERANCE, micro_agreement, micro_errors


def rows_by_quantity(rows):
    return {(r.case, r.quantity): r for r in rows}


def test_values_within_two_percent_of_their_mean_agree():
    checks = {"collision e=1": {"a": {"contact_time": 1.00e-5, "dt": 1e-8}, "b": {"contact_time": 1.01e-5, "dt": 2e-8},
                                "c": {"contact_time": 0.995e-5, "dt": 3e-8}}}
    rows = rows_by_quantity(micro_agreement(checks))
    assert rows[("collision e=1", "contact_time")].agree
    assert ("collision e=1", "dt") not in rows  # bookkeeping, not compared


def test_a_spread_beyond_two_percent_disagrees():
    slower = 4.905 * (1 + 2.5 * MICRO_TOLERANCE)
    checks = {"sliding on base": {"a": {"deceleration": 4.905}, "b": {"deceleration": slower}}}
    (row,) = micro_agreement(checks)
    assert not row.agree and row.known == ()


def test_energy_change_near_zero_is_compared_on_the_impact_energy_scale():
    checks = {"collision e=1": {"a": {"energy_change": 3e-7}, "b": {"energy_change": -4e-6}}}
    (row,) = micro_agreement(checks)
    assert row.agree


def test_a_documented_difference_is_flagged_and_the_others_checked():
    known = {"yade": {("rolling_resistance", "torque"): "facet limit 0.75 μr r m g"}}
    checks = {"rolling resistance": {"numba_dem": {"torque": 4.04e-8}, "liggghts": {"torque": 4.04e-8},
                                     "yade": {"torque": 3.03e-8}}}
    (row,) = micro_agreement(checks, known)
    assert not row.agree and row.known == ("yade",) and row.others_agree
    checks["rolling resistance"]["liggghts"]["torque"] = 5e-8
    (row,) = micro_agreement(checks, known)
    assert row.known == ("yade",) and not row.others_agree


def test_an_undocumented_difference_is_not_excused():
    known = {"yade": {("rolling_resistance", "torque"): "…"}}
    checks = {"collision e=material": {"numba_dem": {"contact_time": 1.2e-5}, "yade": {"contact_time": 1.3e-5}}}
    (row,) = micro_agreement(checks, known)
    assert not row.agree and row.known == ()


def test_a_failed_micro_case_is_reported():
    checks = {"collision e=1": {"a": {"contact_time": 1e-5}, "b": {"error": "RuntimeError: no yade"}}}
    assert micro_agreement(checks) == []
    assert micro_errors(checks) == [("collision e=1", "b", "RuntimeError: no yade")]


@pytest.mark.parametrize("knob", sorted(KNOBS))
def test_every_converge_knob_names_its_command_line_option(knob):
    assert OPTIONS[knob].startswith("--")


def converge_summary(c, aif, rho, rho_u=1.0):
    return {"cohesion": c, "cohesion_u": 300.0, "aif": aif, "aif_u": 2.0, "bulk_density": rho, "bulk_density_u": rho_u}


def test_converge_needs_c_aif_and_bulk_density_within_the_finest():
    finest = converge_summary(1000.0, 30.0, 1550.0)
    assert within_finest(converge_summary(1200.0, 28.0, 1540.0), finest)
    # C and AIF alike, but the coarse cell's bed is 8 % looser: not converged
    assert not within_finest(converge_summary(1200.0, 28.0, 1428.0), finest)
    assert not within_finest(converge_summary(3000.0, 28.0, 1550.0), finest)
    assert not within_finest(converge_summary(1000.0, 40.0, 1550.0), finest)


def test_converge_density_tolerance_is_the_larger_of_seed_spread_and_the_fixed_share():
    finest = converge_summary(1000.0, 30.0, 1500.0, rho_u=float("nan"))  # one seed: no spread
    edge = 1500.0 * (1 - DENSITY_TOLERANCE)
    assert within_finest(converge_summary(1000.0, 30.0, edge + 1.0, rho_u=float("nan")), finest)
    assert not within_finest(converge_summary(1000.0, 30.0, edge - 1.0, rho_u=float("nan")), finest)
    wide = converge_summary(1000.0, 30.0, 1500.0, rho_u=40.0)
    assert within_finest(converge_summary(1000.0, 30.0, 1400.0, rho_u=40.0), wide)  # 100 ≤ 2·√2·40


def shear_result(sigma_swing: float) -> ShearTestResult:
    """A result whose one shear step holds σ = 9 kPa (1 + swing·sin) with τ = 0.5 σ: real data
    structures, made by hand."""
    spec = ShearCellSpec().replace(procedure={"shear_stresses": (9000.0,)})
    rot = np.linspace(0.0, 0.12, 200)
    sigma = 9000.0 * (1.0 + sigma_swing * np.sin(40.0 * rot / 0.12))
    step = StepRecord("shear", 9000.0, rot / 5.0, rot, 0.5 * sigma, sigma, np.full(rot.size, 0.02))
    pre = StepRecord("preshear", 15000.0, rot / 5.0, rot, np.full(rot.size, 7000.0), np.full(rot.size, 15000.0),
                     np.full(rot.size, 0.02))
    return ShearTestResult.from_steps(spec, [pre, step], [1500.0], Provenance("hand", "-", "-", 0, 1.0, 100))


def test_shear_window_diagnostics_see_a_swinging_sigma_and_the_peak_riding_on_it():
    steady = shear_window_diagnostics(shear_result(0.0))
    assert steady["sigma_sd"] == pytest.approx(0.0, abs=1e-12)
    assert steady["steady_friction"] == pytest.approx(0.5)
    swinging = shear_window_diagnostics(shear_result(0.1))
    assert swinging["sigma_sd"] == pytest.approx(0.1 / np.sqrt(2), rel=0.1)
    assert swinging["steady_friction"] == pytest.approx(0.5, rel=1e-3)
    assert swinging["sigma_offset_at_peak"] > 0.05  # the largest τ sits where σ is high


def test_a_result_whose_head_lost_the_bed_is_a_failed_simulation():
    from calibrax.errors import SimulationFailed

    spec = ShearCellSpec().replace(procedure={"shear_stresses": (9000.0,)})
    rot = np.linspace(0.0, 0.12, 50)
    ones = np.ones(rot.size)
    pre = StepRecord("preshear", 15000.0, rot / 5.0, rot, 7000.0 * ones, 15000.0 * ones, 0.02 * ones)
    lifted = StepRecord("shear", 9000.0, rot / 5.0, rot, 30.0 * ones, 40.0 * ones, 0.03 * ones)  # σ ≈ 0
    with pytest.raises(SimulationFailed, match="lost the bed") as info:
        ShearTestResult.from_steps(spec, [pre, lifted], [1500.0], Provenance("hand", "-", "-", 0, 1.0, 100))
    assert info.value.kind == "invalid"


def test_converge_also_needs_the_robust_features_within_the_finest():
    finest = dict(converge_summary(1000.0, 30.0, 1550.0), peak_ratio=0.80, peak_ratio_sd=0.03,
                  preshear_ratio=0.56, preshear_ratio_sd=0.03, seeds_ok=4.0)
    close = dict(finest, peak_ratio=0.84)  # 0.04 ≤ 2·√2·0.015
    assert within_finest(close, finest)
    far = dict(finest, preshear_ratio=0.66)  # 0.10 > 0.042
    assert not within_finest(far, finest)
