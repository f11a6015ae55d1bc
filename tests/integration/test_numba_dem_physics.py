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
