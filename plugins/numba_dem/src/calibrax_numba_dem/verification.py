"""Small, self-contained verification cases of the contact laws and boundaries.

Each function builds a tiny :class:`~calibrax_numba_dem.engine.DEMSystem` (or, with
``device="cuda"``, a :class:`~calibrax_numba_dem.cuda_engine.CudaDEMSystem`), runs it with the same
kernels the shear test uses, and returns what it measured next to the theory, as a plain dict, so
that tests (and a cross-check command on every backend) can compare them. SI units throughout.
"""

from __future__ import annotations

import math

import numpy as np
from calibrax.core.sheartest.verification import CohesiveFunctionVerification
from calibrax.core.sheartest.analytic import hertz_contact_time, rolling_stop, sliding_deceleration, sliding_time

from .contact import beta_from_restitution, effective_moduli
from .engine import make_params, make_system, numba_threads

__all__ = ["NumbaDEMVerification", "hertz_contact_time", "two_sphere_collision", "sliding_on_base", "rolling_resistance",
           "resting_bed_base_load", "pull_off"]


def _params(youngs_modulus: float, poisson_ratio: float, restitution: float, dt: float, **extra: float) -> np.ndarray:
    e_star, g_star = effective_moduli(youngs_modulus, poisson_ratio)
    return make_params(dt=dt, estar=e_star, gstar=g_star, beta=beta_from_restitution(restitution), **extra)


def _two_sphere_collision(speed: float = 0.5, restitution: float = 1.0, radius: float = 0.9e-3,
                         youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                         steps_per_contact: int = 500, device: str = "cpu") -> dict[str, float]:
    """Head-on impact of two equal spheres at relative speed ``speed`` (m/s), no gravity.

    Returns:
        dict with ``contact_time`` (s, measured), ``peak_overlap`` (m, largest overlap),
        ``hertz_contact_time`` (s, theory for e = 1), ``restitution`` (measured −v_rel,out / v_rel,in),
        ``energy_change`` ((KE_out − KE_in)/KE_in) and ``dt`` (s).
    """
    t_c = hertz_contact_time(radius, youngs_modulus, poisson_ratio, density, speed)
    dt = t_c / steps_per_contact
    gap = 0.1 * speed * t_c
    x = np.array([[-radius - gap, 0.0, 0.0], [radius + gap, 0.0, 0.0]])
    v = np.array([[0.5 * speed, 0.0, 0.0], [-0.5 * speed, 0.0, 0.0]])
    sys = make_system(device, x, np.full(2, radius), density, _params(youngs_modulus, poisson_ratio, restitution, dt,
                                                             mu=0.5, mur=0.0), v=v)
    ke0 = sys.kinetic_energy()
    in_contact = 0
    touched = False
    peak = 0.0
    for _ in range(20 * steps_per_contact):
        sys.advance(1)
        overlap = 2.0 * radius - (sys.x[1, 0] - sys.x[0, 0])
        if overlap > 0.0:
            in_contact += 1
            touched = True
            peak = max(peak, overlap)
        elif touched:
            break
    v_out = sys.v[1, 0] - sys.v[0, 0]
    return {"contact_time": in_contact * dt, "peak_overlap": peak, "hertz_contact_time": t_c,
            "restitution": v_out / speed, "energy_change": (sys.kinetic_energy() - ke0) / ke0, "dt": dt}


def _rest_overlap(radius: float, mass: float, e_star: float, g: float) -> float:
    return (mass * g / (4.0 / 3.0 * e_star * math.sqrt(radius))) ** (2.0 / 3.0)


def _sliding_on_base(friction: float = 0.5, speed: float = 0.5, radius: float = 0.9e-3,
                    youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                    restitution: float = 0.3, g: float = 9.81, dt: float = 1.0e-6, device: str = "cpu") -> dict[str, float]:
    """A sphere launched without spin along a flat base of friction ``friction``.

    While it slides, the Coulomb force decelerates it at μs·g. Returns ``deceleration`` (m/s²,
    least-squares slope of v(t) over the middle 80 % of the sliding phase), ``expected`` (μs·g)
    and ``sliding_time`` (s, theory 2 v0 / (7 μs g)).
    """
    e_star, _ = effective_moduli(youngs_modulus, poisson_ratio)
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    z0 = radius - _rest_overlap(radius, m, e_star, g)
    sys = make_system(device, np.array([[0.0, 0.0, z0]]), np.array([radius]), density,
                    _params(youngs_modulus, poisson_ratio, restitution, dt, gz=-g, use_base=1.0,
                            mu_base=friction, mu=friction), v=np.array([[speed, 0.0, 0.0]]))
    t_slide = sliding_time(speed, friction, g)
    chunk = max(1, int(t_slide / dt / 200))
    ts, vs = [], []
    t = 0.0
    while t < t_slide:
        sys.advance(chunk)
        t += chunk * dt
        ts.append(t)
        vs.append(sys.v[0, 0])
    return sliding_deceleration(np.asarray(ts), np.asarray(vs), speed, friction, g)


def _rolling_resistance(rolling_friction: float = 0.5, spin: float = 30.0, radius: float = 0.9e-3,
                       youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                       restitution: float = 0.3, g: float = 9.81, dt: float = 1.0e-6, device: str = "cpu") -> dict[str, float]:
    """A sphere spinning about a horizontal axis on a base without sliding friction, with EPSD2
    rolling resistance ``rolling_friction``.

    Its rolling torque saturates at μr·R*·Fn (R* = R for a wall, Fn = mg), so ω falls linearly.
    Returns ``torque`` (N·m, I·|dω/dt| over the saturated phase), ``expected`` (μr R m g),
    ``peak_torque`` (N·m, largest I·|Δω/Δt| seen step to step).
    """
    e_star, _ = effective_moduli(youngs_modulus, poisson_ratio)
    inertia, expected, t_stop = rolling_stop(radius, density, rolling_friction, spin, g)
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    z0 = radius - _rest_overlap(radius, m, e_star, g)
    sys = make_system(device, np.array([[0.0, 0.0, z0]]), np.array([radius]), density,
                    _params(youngs_modulus, poisson_ratio, restitution, dt, gz=-g, use_base=1.0,
                            mu_base=0.0, mur_base=rolling_friction))
    sys.w[0, 0] = spin
    nsteps = int(0.8 * t_stop / dt)
    ws = np.empty(nsteps)
    for k in range(nsteps):
        sys.advance(1)
        ws[k] = sys.w[0, 0]
    torques = -np.diff(ws) / dt * inertia
    sel = slice(int(0.2 * nsteps), None)
    slope = np.polyfit(np.arange(nsteps)[sel] * dt, ws[sel], 1)[0]
    return {"torque": -float(slope) * inertia, "expected": expected, "peak_torque": float(np.max(np.abs(torques)))}


def _resting_bed_base_load(n_particles: int = 300, friction: float = 0.5, radius: float = 0.9e-3,
                          cell_diameters: float = 8.0, youngs_modulus: float = 25e9, poisson_ratio: float = 0.25,
                          density: float = 3000.0, restitution: float = 0.3, g: float = 9.81, dt: float = 1.0e-6,
                          settle_time: float = 0.06, average_time: float = 0.01, seed: int = 0, device: str = "cpu") -> dict[str, float]:
    """A bed poured into a cylinder with a frictionless wall *and* a frictionless base.

    Neither wall can carry shear, so at rest the base carries the bed's full weight. The bed
    settles for at least ``settle_time`` and until no particle moves faster than 1 mm/s. Returns
    ``base_force`` (N, time-averaged over the last ``average_time``), ``weight`` (N, Σ m g) and
    ``kinetic_energy`` (J, at the end).
    """
    from calibrax.core.sheartest.packing import lattice_column

    rc = 0.5 * cell_diameters * 2.0 * radius
    rng = np.random.default_rng(seed)
    x = lattice_column(np.full(n_particles, radius), rc, rng)
    sys = make_system(device, x, np.full(n_particles, radius), density,
                    _params(youngs_modulus, poisson_ratio, restitution, dt, gz=-g, mu=friction, use_base=1.0,
                            use_cyl=1.0, rc=rc))
    t = 0.0
    while t < settle_time or (t < 10 * settle_time and np.sqrt(np.max(np.sum(sys.v**2, axis=1))) > 1e-3):
        sys.advance(int(0.005 / dt))
        t += 0.005
    sys.take_accumulators()
    sys.advance(int(average_time / dt))
    _, _, base, _ = sys.take_accumulators()
    return {"base_force": base, "weight": float(np.sum(sys.mass) * g), "kinetic_energy": sys.kinetic_energy()}


def _pull_off(energy_density: float = 1.0e8, radius: float = 0.9e-3, youngs_modulus: float = 25e9,
              poisson_ratio: float = 0.25, density: float = 3000.0, steps: int = 4000, device: str = "cpu") -> dict[str, float]:
    """Two spheres with SJKR cohesion ``energy_density`` (J/m³) pulled apart along x, and a sphere
    pulled off the base along z, displacement-controlled, without damping (restitution 1: the
    pull-off force is a quasi-static quantity) or gravity.

    The contact starts at three times the overlap of greatest attraction and opens in ``steps``
    equal steps; the force on the moving sphere is read after each step. Returns
    ``pull_off_force`` and ``wall_pull_off_force`` (N, the largest attraction seen), and
    ``expected`` and ``wall_expected`` (N, 2/3 π³ k³ R*² / E*² with R* = R/2 and R).
    """
    from calibrax.core.sheartest.cohesion import sjkr_pull_off_force, sjkr_pull_off_overlap

    e_star, _ = effective_moduli(youngs_modulus, poisson_ratio)
    out: dict[str, float] = {}
    for key, reff, axis in (("pull_off_force", 0.5 * radius, 0), ("wall_pull_off_force", radius, 2)):
        start = 3.0 * sjkr_pull_off_overlap(energy_density, reff, e_star)
        stop = -0.2 * sjkr_pull_off_overlap(energy_density, reff, e_star)
        dt = 1.0e-9
        speed = (start - stop) / (steps * dt)
        wall = axis == 2
        x = np.array([[0.0, 0.0, radius - start]]) if wall else np.array([[0.0, 0.0, 0.0], [2.0 * radius - start, 0.0, 0.0]])
        params = _params(youngs_modulus, poisson_ratio, 1.0, dt, coh=energy_density, use_base=1.0 if wall else 0.0)
        sys = make_system(device, x, np.full(len(x), radius), density, params)
        moving = len(x) - 1
        attraction = 0.0
        for k in range(steps + 1):
            sys.x[:] = x
            sys.x[moving, axis] += k * (start - stop) / steps
            sys.v[:] = 0.0
            sys.v[moving, axis] = speed
            sys.w[:] = 0.0
            sys.advance(1)
            attraction = max(attraction, -float(sys.f[moving, axis]))
        out[key] = attraction
    out["expected"] = sjkr_pull_off_force(energy_density, 0.5 * radius, e_star)
    out["wall_expected"] = sjkr_pull_off_force(energy_density, radius, e_star)
    return out


def _threaded(impl):
    import functools

    @functools.wraps(impl)
    def run(*args, threads: int = 1, **kwargs):
        with numba_threads(threads):
            return impl(*args, **kwargs)
    run.__name__ = impl.__name__.lstrip("_")
    run.__qualname__ = run.__name__
    return run


two_sphere_collision = _threaded(_two_sphere_collision)
sliding_on_base = _threaded(_sliding_on_base)
rolling_resistance = _threaded(_rolling_resistance)
resting_bed_base_load = _threaded(_resting_bed_base_load)
pull_off = _threaded(_pull_off)


class NumbaDEMVerification(CohesiveFunctionVerification):
    """numba_dem's analytic checks for the crosscheck (:class:`calibrax.core.sheartest.verification.Verification`)."""

    name = "numba_dem"
    known_differences = {}
    collision = staticmethod(two_sphere_collision)
    sliding = staticmethod(sliding_on_base)
    rolling = staticmethod(rolling_resistance)
    pull_off = staticmethod(pull_off)
