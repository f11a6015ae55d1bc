"""numba_dem contact laws and boundaries against theory (real engine, tiny systems)."""

from __future__ import annotations

import pytest

from calibrax_numba_dem import verification as V


@pytest.mark.parametrize("speed", [0.1, 0.5, 2.0])
def test_hertz_contact_time(speed: float) -> None:
    r = V.two_sphere_collision(speed=speed, restitution=1.0)
    assert r["contact_time"] == pytest.approx(r["hertz_contact_time"], rel=0.02)


@pytest.mark.parametrize("restitution", [0.3, 0.7])
@pytest.mark.parametrize("speed", [0.05, 0.5, 3.0])
def test_restitution_independent_of_speed(restitution: float, speed: float) -> None:
    r = V.two_sphere_collision(speed=speed, restitution=restitution)
    assert r["restitution"] == pytest.approx(restitution, rel=0.02)


def test_peak_overlap_of_elastic_impact_matches_hertz() -> None:
    """δ_max = (15 m* v² / (16 E* √R*))^(2/5) for two equal spheres (m* = m/2, R* = R/2)."""
    import math

    radius, e, nu, rho, v = 0.9e-3, 25e9, 0.25, 3000.0, 0.5
    r = V.two_sphere_collision(speed=v, restitution=1.0, radius=radius, youngs_modulus=e, poisson_ratio=nu,
                               density=rho)
    mstar = 4.0 / 3.0 * math.pi * radius**3 * rho / 2.0
    estar = e / (2.0 * (1.0 - nu**2))
    theory = (15.0 * mstar * v**2 / (16.0 * estar * math.sqrt(radius / 2.0))) ** 0.4
    assert r["peak_overlap"] == pytest.approx(theory, rel=0.01)


def test_energy_conserved_for_elastic_impact() -> None:
    r = V.two_sphere_collision(speed=1.0, restitution=1.0)
    assert abs(r["energy_change"]) < 0.005


@pytest.mark.parametrize("friction", [0.3, 0.7])
def test_sliding_sphere_decelerates_at_mu_g(friction: float) -> None:
    r = V.sliding_on_base(friction=friction, speed=0.5)
    assert r["deceleration"] == pytest.approx(r["expected"], rel=0.02)


def test_rolling_torque_saturates_at_mur_r_fn() -> None:
    r = V.rolling_resistance(rolling_friction=0.5, spin=30.0)
    assert r["torque"] == pytest.approx(r["expected"], rel=0.02)
    assert r["peak_torque"] <= r["expected"] * 1.02


def test_resting_bed_weight_on_frictionless_base() -> None:
    r = V.resting_bed_base_load(n_particles=150)
    assert r["base_force"] == pytest.approx(r["weight"], rel=0.01)
