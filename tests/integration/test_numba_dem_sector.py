"""numba_dem's periodic sector (``geometry.sector``) against the full cell: a contact across a face
is the contact inside, a particle crossing a face keeps its momentum, spin and wall-contact
history, and a sheared sector carries the torque of its k-fold replica in the full cell."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from calibrax.core.sheartest import ShearCellSpec
from calibrax.core.sheartest.engine_control import RunLog
from calibrax.core.sheartest.procedure_stages import Consolidate, InsertBlades, Pour
from calibrax_numba_dem.contact import beta_from_restitution, effective_moduli
from calibrax_numba_dem.engine import DEMSystem, make_params, numba_threads
from calibrax_numba_dem.layout import H_ACC_F, H_ACC_N, H_ACC_T, H_DAMP, H_FTARGET, H_MASS, P_SECTOR
from calibrax_numba_dem.procedure import ShearTestDriver

pytestmark = pytest.mark.numba_dem

RADIUS, DENSITY = 0.9e-3, 3000.0


def _rot(a: np.ndarray, angle: float) -> np.ndarray:
    """Vectors (…, 3) rotated by ``angle`` rad about z."""
    c, s = math.cos(angle), math.sin(angle)
    out = np.array(a, dtype=float, copy=True)
    out[..., 0] = c * a[..., 0] - s * a[..., 1]
    out[..., 1] = s * a[..., 0] + c * a[..., 1]
    return out


def _params(sector: int, dt: float, **extra: float) -> np.ndarray:
    e_star, g_star = effective_moduli(1.0e9, 0.25)
    return make_params(dt=dt, estar=e_star, gstar=g_star, beta=beta_from_restitution(0.5), mu=0.5, mur=0.3,
                       sector=2.0 * math.pi / sector if sector > 1 else 0.0, **extra)


def _unwrap(sector_value: np.ndarray, reference: np.ndarray, opening: float) -> np.ndarray:
    """``sector_value`` (3,) rotated by the multiple of Θ that brings it closest to ``reference``."""
    options = [_rot(sector_value, m * opening) for m in (-1, 0, 1)]
    return min(options, key=lambda o: float(np.linalg.norm(o - reference)))


def _run_side_by_side(full: DEMSystem, sec: DEMSystem, steps: int) -> tuple[np.ndarray, ...]:
    """Advance both one step at a time, rebuilding the lists before each (so that a particle is
    wrapped into the wedge the step after it left it, in contact or not); the full run's
    (positions, velocities, spins, forces), shape (steps, 4, N, 3), and the sector run's unwrapped
    onto them."""
    opening = sec.params[P_SECTOR]
    rec_f, rec_s = [], []
    with numba_threads(1):
        for _ in range(steps):
            full.rebuild_lists()
            sec.rebuild_lists()
            full.advance(1)
            sec.advance(1)
            rec_f.append(np.stack([full.x, full.v, full.w, full.f]).copy())
            rows = []
            for i in range(full.n):
                m = min((-1, 0, 1), key=lambda m: float(np.linalg.norm(_rot(sec.x[i], m * opening) - full.x[i])))
                rows.append([_rot(a[i], m * opening) for a in (sec.x, sec.v, sec.w, sec.f)])
            rec_s.append(np.transpose(np.array(rows), (1, 0, 2)))
    return np.array(rec_f), np.array(rec_s)


@pytest.mark.parametrize("crossing", [0, 1], ids=["partner crosses", "owner crosses"])
def test_a_contact_across_a_face_is_the_contact_inside(crossing: int) -> None:
    """Two spheres meet obliquely, spinning, across the face θ = 0 of a quarter sector (one of them
    held as its image by the face θ = π/2), and one crosses the face while in contact (the pair's
    owner, whose springs turn with it, or its partner): every step's force,
    position, velocity and spin equal the full cell's to round-off (the sliding and rolling springs
    go with the pair across the face)."""
    k, rho0, dt = 4, 10.0e-3, 2.0e-7
    x = np.array([[rho0, 0.2 * RADIUS, 0.0], [rho0 + math.sqrt((2.0 * RADIUS + 2e-6) ** 2 - (0.4 * RADIUS) ** 2),
                                                  -0.2 * RADIUS, 0.0]])
    v = np.array([[0.05, -3.0, 0.02], [-0.05, -3.0, -0.03]])
    w = np.array([[10.0, -20.0, 40.0], [-30.0, 5.0, -15.0]])
    order = [0, 1] if crossing == 0 else [1, 0]  # particle 1 owns the pair (neighbours.owns)
    x, v, w = x[order], v[order], w[order]
    full = DEMSystem(x, np.full(2, RADIUS), DENSITY, _params(1, dt), v=v)
    full.w[:] = w
    xs = x.copy()
    vs, ws = v.copy(), w.copy()
    opening = 2.0 * math.pi / k
    b = order[1]  # the sphere beyond the face, held as its image
    xs[b], vs[b], ws[b] = _rot(x[b], opening), _rot(v[b], opening), _rot(w[b], opening)
    sec = DEMSystem(xs, np.full(2, RADIUS), DENSITY, _params(k, dt), v=vs)
    sec.w[:] = ws
    ref, got = _run_side_by_side(full, sec, 1500)
    force = np.abs(ref[:, 3]).max()
    a = order[0]
    touching = np.abs(ref[:, 3, a]).max(axis=1) > 0
    assert touching.sum() > 100, "the spheres must stay in contact long enough to slide and roll"
    side = np.sign(ref[touching, 0, a, 1])
    assert side.max() > 0 > side.min(), "sphere 0 must cross the face θ = 0 while in contact"
    assert np.all(np.arctan2(sec.x[:, 1], sec.x[:, 0]) >= 0), "the sector keeps its particles in the wedge"
    np.testing.assert_allclose(got[:, 3], ref[:, 3], rtol=0, atol=1e-9 * force)
    np.testing.assert_allclose(got[:, 0], ref[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[:, 1], ref[:, 1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[:, 2], ref[:, 2], rtol=0, atol=1e-6)


def test_a_particle_crossing_a_face_keeps_its_momentum_spin_and_wall_history() -> None:
    """A sphere slides and spins along the base and the (frictional) vessel wall across the face
    θ = π/2 of a quarter sector: its trajectory equals the full cell's to round-off, which it does
    only if the base's and the wall's tangential and rolling springs turn with it."""
    k, rc, dt = 4, 12.0e-3, 2.0e-7
    e_star, _ = effective_moduli(1.0e9, 0.25)
    mass = 4.0 / 3.0 * math.pi * RADIUS**3 * DENSITY
    overlap = (mass * 9.81 / (4.0 / 3.0 * e_star * math.sqrt(RADIUS))) ** (2.0 / 3.0)
    theta0 = math.pi / 2 - 0.02
    rho = rc - RADIUS + 2e-7
    x = np.array([[rho * math.cos(theta0), rho * math.sin(theta0), RADIUS - overlap]])
    tangent = np.array([-math.sin(theta0), math.cos(theta0), 0.0])
    radial = np.array([math.cos(theta0), math.sin(theta0), 0.0])
    v = (1.0 * tangent + 0.01 * radial)[None, :]
    walls = {"gz": -9.81, "use_base": 1.0, "mu_base": 0.4, "mur_base": 0.2, "use_cyl": 1.0, "rc": rc,
             "mu_wall": 0.3, "mur_wall": 0.1}
    full = DEMSystem(x, np.array([RADIUS]), DENSITY, _params(1, dt, **walls), v=v)
    full.w[0] = [3.0, -2.0, 50.0]
    sec = DEMSystem(x.copy(), np.array([RADIUS]), DENSITY, _params(k, dt, **walls), v=v.copy())
    sec.w[0] = [3.0, -2.0, 50.0]
    ref, got = _run_side_by_side(full, sec, 4000)
    theta_end = math.atan2(ref[-1, 0, 0, 1], ref[-1, 0, 0, 0])
    assert theta_end > math.pi / 2 + 0.02, "the sphere must have crossed the face"
    assert math.atan2(sec.x[0, 1], sec.x[0, 0]) < math.pi / 2, "and been wrapped into the wedge"
    assert np.count_nonzero(sec.wid >= 0) == 2 and np.abs(sec.whist).max() > 0
    speed = np.linalg.norm(ref[:, 1, 0], axis=1)
    assert speed[-1] < 0.99 * speed[0], "the wall's and the base's friction must have slowed it"
    np.testing.assert_allclose(got[:, 0], ref[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[:, 1], ref[:, 1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[:, 2], ref[:, 2], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[:, 3], ref[:, 3], rtol=0, atol=1e-9 * np.abs(ref[:, 3]).max())


def test_a_sheared_sector_carries_the_torque_of_its_replica_in_the_full_cell() -> None:
    """A quarter of the ``tiny`` cell, consolidated and turning under the preshear stress, and the
    full cell made of four rotated copies of it (with the same frictionless core, the contact
    histories cleared in both) go on for 400 steps: the full cell's head force and torque are
    four times the sector's, and each copy's particles move as the sector's."""
    k = 4
    spec = ShearCellSpec.preset("tiny").replace(material={"youngs_modulus": 1.0e9}, geometry={"sector": k},
                                                procedure={"preshear_rotation": 0.02},
                                                numerics={"dt_fraction": 0.2, "threads": 1}).validate()
    runner = ShearTestDriver(spec, RunLog(logging.getLogger("test_numba_dem_sector")))
    sigma = spec.procedure.preshear_stress
    runner.run((Pour(), InsertBlades(sigma), Consolidate(sigma)))
    sec = runner.sys
    opening = 2.0 * math.pi / k
    n = sec.n
    params = sec.params.copy()
    params[P_SECTOR] = 0.0
    full = DEMSystem(np.concatenate([_rot(sec.x, m * opening) for m in range(k)]), np.tile(sec.rad, k), DENSITY,
                     params, head=sec.head.copy(), v=np.concatenate([_rot(sec.v, m * opening) for m in range(k)]))
    full.w[:] = np.concatenate([_rot(sec.w, m * opening) for m in range(k)])
    full.head[[H_ACC_F, H_ACC_T, H_ACC_N]] = 0.0
    full.head[[H_FTARGET, H_MASS, H_DAMP]] *= k  # the sector holds 1/k of the head's load, mass, damping
    for s in (full, sec):
        s.hist[:] = 0.0
        s.rhist[:] = 0.0
        s.whist[:] = 0.0
        s.wrhist[:] = 0.0
        s.wid[:] = -1
        s.x_build[:] = s.x + 1e9
        s._started = True
    sec.head[[H_ACC_F, H_ACC_T, H_ACC_N]] = 0.0
    with numba_threads(1):
        sec.advance(400)
        full.advance(400)
    f_sec, t_sec, _, _ = sec.take_accumulators()
    f_full, t_full, _, _ = full.take_accumulators()
    assert t_sec > 0 and f_sec > 0
    assert f_full == pytest.approx(k * f_sec, rel=1e-7)
    assert t_full == pytest.approx(k * t_sec, rel=1e-7)
    replica = full.x.reshape(k, n, 3)
    gaps = np.min([np.linalg.norm(replica[m] - sec.x, axis=1) for m in range(k)], axis=0)
    assert gaps.max() < 1e-10


def test_a_resumed_campaign_at_a_sector_cell_repeats_nothing(tmp_path) -> None:
    """A campaign on a half sector of the smoke cell with branched steps runs its two Sobol points;
    given one more batch it runs only that batch, and ``status`` names the sector."""
    import yaml

    from calibrax import CampaignStore
    from tests.conftest import SMOKE_CELL, calibrax_cli, write_backend_campaign

    cell = {**SMOKE_CELL, "geometry": {"sector": 2}, "procedure": {**SMOKE_CELL["procedure"], "branches": True}}
    path = write_backend_campaign(tmp_path, "numba_dem", cell=cell, budget={"initial": 2, "iterations": 0})
    first = calibrax_cli("run", str(path), timeout=1800)
    assert first.returncode == 0, first.stderr[-3000:]
    store = tmp_path / "runs/campaign.h5"
    before = {p.id: [s.wall_time for s in p.sims] for p in CampaignStore(store).points()}
    assert len(before) == 2
    config = yaml.safe_load(path.read_text())
    config["budget"]["iterations"] = 1
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    again = calibrax_cli("run", str(path), timeout=1800)
    assert again.returncode == 0, again.stderr[-3000:]
    points = CampaignStore(store).points()
    assert len(points) == 4 and all(p.status == "done" for p in points)
    assert {p.id: [s.wall_time for s in p.sims] for p in points if p.id in before} == before
    assert "cell: 288 particles, 9.0 per diameter, a 1/2 sector" in again.stderr, again.stderr[:2000]
    status = calibrax_cli("status", str(store))
    assert "a 1/2 sector" in status.stdout, status.stdout


def test_a_wrapped_particles_blade_and_rib_contacts_move_to_the_image_element() -> None:
    """A particle rotated by wΘ touches, instead of blade (rib) b, the blade (rib) that the rotation
    carries b onto: its direction is b's turned by wΘ; the vessel, base, disc and core stay."""
    from calibrax_numba_dem.geometry import EID_BASE, EID_BLADE0, EID_CORE, EID_CYL, EID_DISC, EID_RIB0
    from calibrax_numba_dem.periodic import _image_element

    n, k, phi = 12, 4, 0.3
    opening = 2.0 * math.pi / k
    for w in (-1, 1):
        for b in range(n):
            blade = _image_element(EID_BLADE0 + b, w, n, n, k) - EID_BLADE0
            rib = _image_element(EID_RIB0 + b, w, n, n, k) - EID_RIB0
            for first, image, offset in ((b, blade, phi), (b, rib, 0.0)):
                turned = offset + 2.0 * math.pi * first / n + w * opening
                assert math.cos(offset + 2.0 * math.pi * image / n - turned) == pytest.approx(1.0)
        for eid in (EID_CYL, EID_BASE, EID_DISC, EID_CORE):
            assert _image_element(eid, w, n, n, k) == eid
