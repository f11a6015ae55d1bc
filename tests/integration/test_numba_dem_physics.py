"""numba_dem contact laws and boundaries against theory (real engine, tiny systems)."""

from __future__ import annotations

import pytest

from calibrax_numba_dem import verification as V

pytestmark = pytest.mark.numba_dem


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


# ---------------------------------------------------------------- the contact law's definitions
# LIGGGHTS 3.8's (rolling_model_epsd2.h, tangential_model_history.h), checked on the kernel itself:
# the micro cases above only see the limits μs|F_n| and μr R*|F_n|, not the stiffnesses and the
# dashpot rule below them.
def _one_contact_step(shear=(0.0, 0.0, 0.0), vt=(0.0, 0.0, 0.0), spin=(0.0, 0.0, 0.0), mu=0.5, mur=0.5):
    """One step of a particle–wall contact with normal +z at overlap 1e-7 m (R = 0.9 mm,
    E = 25 GPa, ν = 0.25, e = 0.3): returns (force, rolling torque, updated spring, k_t, γ_t, F_n, R)."""
    import math

    import numpy as np
    from calibrax_numba_dem.contact import beta_from_restitution, contact, effective_moduli

    radius, delta, dt = 0.9e-3, 1e-7, 1e-7
    mass = 4.0 / 3.0 * math.pi * radius**3 * 3000.0
    e_star, g_star = effective_moduli(25e9, 0.25)
    beta = beta_from_restitution(0.3)
    hist = np.array([shear], dtype=float)
    rhist = np.zeros((1, 3))
    out = contact(0.0, 0.0, 1.0, delta, radius, mass, vt[0], vt[1], vt[2], 0.0, 0.0, 0.0, spin[0], spin[1],
                  spin[2], e_star, g_star, beta, mu, mur, 0.0, dt, hist, rhist, 0)
    sq = math.sqrt(radius * delta)
    kt = 8.0 * g_star * sq
    gt = -2.0 * math.sqrt(5.0 / 6.0) * beta * math.sqrt(2.0 * e_star * sq * mass) * math.sqrt(4.0 * g_star / e_star)
    return np.array(out[:3]), np.array(out[6:9]), hist[0].copy(), kt, gt, out[9], radius, dt


def test_rolling_stiffness_is_epsd2_kt_r_squared() -> None:
    """EPSD2: the rolling torque grows by k_r ω Δt per step with k_r = k_t R*² (not EPSD's 2.25 k_n μr² R*²)."""
    _, torque, _, kt, _, _, radius, dt = _one_contact_step(spin=(3.0, 0.0, 0.0))
    assert torque[0] == pytest.approx(-kt * radius**2 * 3.0 * dt, rel=1e-12)
    assert torque[1] == 0.0 and torque[2] == 0.0


def test_sticking_contact_adds_dashpot_past_the_coulomb_limit() -> None:
    """LIGGGHTS slides a contact only when the *spring* exceeds μs|F_n|; while it sticks the dashpot adds on top."""
    _, _, _, kt, gt, fn, _, dt = _one_contact_step()
    s0 = 0.9 * 0.5 * fn / kt  # spring force 90 % of the limit
    v = 0.02  # m/s: a dashpot force far above the limit's remaining 10 %
    force, _, spring, kt, gt, fn, _, dt = _one_contact_step(shear=(s0, 0.0, 0.0), vt=(v, 0.0, 0.0))
    s1 = s0 + v * dt
    assert kt * s1 < 0.5 * fn
    assert force[0] == pytest.approx(-kt * s1 - gt * v, rel=1e-12)
    assert abs(force[0]) > 0.5 * fn
    assert spring[0] == pytest.approx(s1, rel=1e-12)


def test_sliding_contact_is_cut_to_the_coulomb_limit_without_dashpot() -> None:
    _, _, _, kt, _, fn, _, _ = _one_contact_step()
    force, _, spring, kt, _, fn, _, _ = _one_contact_step(shear=(2.0 * 0.5 * fn / kt, 0.0, 0.0), vt=(0.5, 0.0, 0.0))
    assert force[0] == pytest.approx(-0.5 * fn, rel=1e-12)
    assert spring[0] == pytest.approx(0.5 * fn / kt, rel=1e-12)


def test_resting_bed_weight_on_frictionless_base() -> None:
    r = V.resting_bed_base_load(n_particles=150)
    assert r["base_force"] == pytest.approx(r["weight"], rel=0.01)


# ---------------------------------------------------------------- engine invariants (half lists)
def _cluster(n: int = 200, seed: int = 1):
    """A loose random cluster of spheres with friction and rolling friction, no walls, no gravity,
    collapsing on its centre: every contact law is exercised and the lists are rebuilt."""
    import numpy as np

    from calibrax_numba_dem.contact import beta_from_restitution, effective_moduli
    from calibrax_numba_dem.engine import DEMSystem, make_params

    rng = np.random.default_rng(seed)
    r = 0.9e-3
    side = int(np.ceil(n ** (1 / 3)))
    grid = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), -1).reshape(-1, 3)[:n]
    x = (grid - side / 2) * 2.15 * r + rng.uniform(-0.02 * r, 0.02 * r, (n, 3))
    v = -150.0 * x + rng.normal(0, 0.1, (n, 3))
    e_star, g_star = effective_moduli(25e9, 0.25)
    params = make_params(dt=2e-7, estar=e_star, gstar=g_star, beta=beta_from_restitution(0.5), mu=0.5, mur=0.3)
    return DEMSystem(x, np.full(n, r) * rng.uniform(0.95, 1.05, n), 3000.0, params, v=v)


def test_pair_forces_conserve_momentum() -> None:
    """Each pair is computed once and acts as ±F: no walls, no gravity → Σ m v constant."""
    import numpy as np

    from calibrax_numba_dem.engine import numba_threads

    s = _cluster()
    p0 = (s.mass[:, None] * s.v).sum(axis=0)
    with numba_threads(1):
        s.advance(4000)
    p1 = (s.mass[:, None] * s.v).sum(axis=0)
    assert s.pair_count > 0
    assert np.abs(p1 - p0).max() < 1e-12 * float(np.sum(s.mass * np.linalg.norm(s.v, axis=1)))


def test_same_result_for_any_thread_count() -> None:
    """Forces are summed in a fixed order whatever the threads: bit-identical states."""
    import copy

    import numba
    import numpy as np

    from calibrax_numba_dem.engine import numba_threads

    assert numba.config.NUMBA_NUM_THREADS >= 2, "tests/conftest.py sets NUMBA_NUM_THREADS=2 on 1-core machines"
    first = _cluster()
    second = copy.deepcopy(first)
    with numba_threads(1):
        first.advance(3000)
    with numba_threads(2):
        second.advance(3000)
    assert first.list_builds > 1
    for name in ("x", "v", "w", "hist", "rhist"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))


def test_history_carried_over_list_rebuild() -> None:
    """A rebuild keeps every surviving pair's tangential and rolling history (keyed by pair)."""
    import numpy as np

    from calibrax_numba_dem.engine import numba_threads

    s = _cluster()
    with numba_threads(1):
        s.advance(4000)

    def by_pair(sys_):
        out = {}
        for i in range(sys_.n):
            for p in range(sys_.start[i], sys_.start[i + 1]):
                out[(i, int(sys_.pj[p]))] = (sys_.hist[p].copy(), sys_.rhist[p].copy())
        return out

    before = by_pair(s)
    assert sum(np.any(h != 0) for h, _ in before.values()) > 10
    s.x += 1e-6 * np.sin(np.arange(s.n))[:, None]  # a different binning, the same pairs
    s.rebuild_lists()
    after = by_pair(s)
    common = set(before) & set(after)
    assert len(common) > 0.9 * len(before)
    for key in common:
        np.testing.assert_array_equal(before[key][0], after[key][0])
        np.testing.assert_array_equal(before[key][1], after[key][1])
    for key in set(after) - set(before):
        assert not np.any(after[key][0]) and not np.any(after[key][1])
