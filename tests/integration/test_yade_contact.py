"""YADE backend: the contact law against Hertz theory (real ``yade`` binary, no mocks)."""

from __future__ import annotations

import math

import pytest
from calibrax_yade.contact import contact_params, effective_moduli, facet_material
from calibrax_yade.verification import (KNOWN_DIFFERENCES, damped_hertz_impact, damped_hertz_restitution,
                                       liggghts_beta, rolling_resistance, sliding_on_base, thornton_beta,
                                       two_sphere_collision)

from calibrax.core.sheartest import ShearCellSpec

pytestmark = pytest.mark.yade


def test_elastic_collision_matches_hertz_contact_time():
    out = two_sphere_collision(speed=0.5, restitution=1.0)
    assert out["contact_time"] == pytest.approx(out["hertz_contact_time"], rel=0.02)
    assert out["restitution"] == pytest.approx(1.0, rel=0.02)
    assert abs(out["energy_change"]) < 1e-3
    # YADE built LIGGGHTS' normal coefficient 4/3 E* sqrt(R*) from the converted parameters
    assert out["kno"] == pytest.approx(out["kno_theory"], rel=1e-9)


def test_damped_collision_matches_requested_restitution():
    out = two_sphere_collision(speed=0.5, restitution=0.3)
    assert out["restitution"] == pytest.approx(0.3, rel=0.02)
    assert out["restitution"] == pytest.approx(out["damped_restitution"], rel=0.02)
    assert out["energy_change"] < 0


def test_damped_collision_follows_yades_no_tension_law_not_liggghts():
    """YADE 2023.02 turns en into Thornton's β_n and clips the damped force at zero: the same e
    as LIGGGHTS' law, but a longer, shallower contact (a documented KNOWN_DIFFERENCE)."""
    out = two_sphere_collision(speed=0.5, restitution=0.3)
    assert out["betan"] == pytest.approx(out["betan_thornton"], rel=1e-9)
    assert out["contact_time"] == pytest.approx(out["damped_contact_time"], rel=0.01)
    assert out["peak_overlap"] == pytest.approx(out["damped_peak_overlap"], rel=0.01)
    assert out["contact_time"] > 1.02 * out["liggghts_contact_time"]
    assert out["peak_overlap"] < 0.95 * out["liggghts_peak_overlap"]
    assert ("two_sphere_collision", "contact_time") in KNOWN_DIFFERENCES


def test_yades_and_liggghts_damped_laws_give_the_same_restitution():
    for e in (0.3, 0.5, 0.8):
        yade = damped_hertz_impact(e, 0.9e-3, 25e9, 0.25, 3000.0, 0.5, law="yade")
        lig = damped_hertz_impact(e, 0.9e-3, 25e9, 0.25, 3000.0, 0.5, law="liggghts")
        assert yade["restitution"] == pytest.approx(e, rel=0.01)
        assert lig["restitution"] == pytest.approx(e, rel=0.01)
        assert thornton_beta(e) > liggghts_beta(e) > 0
    assert thornton_beta(1.0) == liggghts_beta(1.0) == 0.0


def test_sliding_on_a_base_facet_decelerates_at_mu_g():
    out = sliding_on_base(friction=0.5)
    assert out["deceleration"] == pytest.approx(out["expected"], rel=0.02)


def test_rolling_on_a_base_facet_saturates_at_three_quarters_of_liggghts_limit():
    out = rolling_resistance(rolling_friction=0.5)
    assert out["torque"] == pytest.approx(out["yade_limit"], rel=0.02)
    assert out["yade_limit"] == pytest.approx(0.75 * out["expected"])
    assert out["peak_torque"] <= 1.05 * out["yade_limit"]


def test_damped_hertz_ode_reproduces_liggghts_restitution():
    e, t = damped_hertz_restitution(0.5, 0.9e-3, 25e9, 0.25, 3000.0, 0.5)
    assert e == pytest.approx(0.5, rel=0.01)
    assert t > 0


def test_facet_material_restores_liggghts_wall_stiffness():
    e, nu = 25e9, 0.25
    ew, nuw = facet_material(e, nu)
    e_star, g_star = effective_moduli(e, nu)
    # YADE 2023.02 pair moduli, facet contact radius R = 2r/3, against LIGGGHTS' wall R* = r
    ey = 1.0 / ((1 - nu**2) / e + (1 - nuw**2) / ew)
    g, gw = e / (2 * (1 + nu)), ew / (2 * (1 + nuw))
    gy = 1.0 / ((2 - nu) / g + (2 - nuw) / gw)
    assert ey * math.sqrt(2.0 / 3.0) == pytest.approx(e_star, rel=1e-12)
    assert gy * math.sqrt(2.0 / 3.0) == pytest.approx(g_star, rel=1e-12)


def test_rolling_parameters_follow_epsd2():
    spec = ShearCellSpec.preset("tiny")
    cp = contact_params(spec)
    assert cp.eta == pytest.approx(spec.material.rolling_friction / 2)
    # EPSD2 as LIGGGHTS 3.8 defines it: k_r = k_t R*², k_t = 8 G* √(R* δ), at the Hertz overlap of a
    # pair (R* = r/2) carrying σ_pre (2r)²: F = 4/3 E* √R* δ^{3/2}
    m, r = spec.material, spec.radius
    e_star = m.youngs_modulus / (2 * (1 - m.poisson_ratio**2))
    g_star = m.youngs_modulus / (4 * (2 - m.poisson_ratio) * (1 + m.poisson_ratio))
    force = spec.procedure.preshear_stress * (2 * r) ** 2
    delta = (force / (4 / 3 * e_star * math.sqrt(r / 2))) ** (2 / 3)
    assert cp.krot == pytest.approx(8 * g_star * math.sqrt(r / 2 * delta) * (r / 2) ** 2, rel=1e-12)
