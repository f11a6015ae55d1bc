"""Verification of the YADE contact law against Hertz theory, run with the real ``yade`` binary.

``two_sphere_collision``, ``sliding_on_base`` and ``rolling_resistance`` have the signatures and
return keys of ``calibrax_numba_dem.verification``, so that ``calibrax crosscheck`` can set the
backends side by side; extra keys carry the theory of YADE's own law and the coefficients YADE
built from the converted parameters. ``KNOWN_DIFFERENCES`` lists the micro-level quantities in which
YADE 2023.02's contact law differs from LIGGGHTS' by construction (the cross-check shows why).
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import numpy as np
from calibrax.core.sheartest.verification import FunctionVerification
from calibrax.core.sheartest.analytic import hertz_contact_time, rolling_stop, sliding_deceleration, sliding_time
from calibrax.core.sheartest import Material, ShearCellSpec
from calibrax.errors import SimulationFailed

from .contact import contact_params, effective_moduli
from .runner import find_yade, run_yade, script_path, write_params

__all__ = ["YadeVerification", "hertz_contact_time", "thornton_beta", "liggghts_beta", "damped_hertz_impact", "damped_hertz_restitution",
           "two_sphere_collision", "sliding_on_base", "rolling_resistance"]


_DAMPING = ("YADE 2023.02 turns en into the damping ratio of a no-tension law (Thornton et al. 2013; the "
            "damped normal force is clipped at 0), LIGGGHTS/numba_dem use β = ln e/√(ln²e + π²) and let the "
            "force turn attractive at the end of a contact: e is the same, but for e < 1 YADE's damping is "
            "stronger (β_n 0.454 instead of 0.327 at e = 0.3), so its contact is longer (+3.7 %) and shallower "
            "(peak overlap −11 %); see damped_hertz_impact(law='yade'|'liggghts')")
_ROLLING = ("YADE has one rolling limit η·R_mean·F_n for every contact; η = μr/2 is exact between equal spheres, "
            "but a facet contact has R_mean = (2r + r)/2, so on the base the limit is 0.75 μr r m g (LIGGGHTS, "
            "numba_dem: μr r m g)")
#: (function, quantity) → why YADE 2023.02's contact law differs there from LIGGGHTS' by construction
KNOWN_DIFFERENCES = {
    ("two_sphere_collision", "contact_time"): _DAMPING,
    ("two_sphere_collision", "peak_overlap"): _DAMPING,
    ("rolling_resistance", "torque"): _ROLLING,
    ("rolling_resistance", "peak_torque"): _ROLLING,
}

#: Thornton et al. (2013), Table 2: fit of ln of the no-tension damped Hertz law's (1 + e)⁻² (1 − 1/(1 + β²))
#: against e, used by YADE 2023.02's ``Ip2_FrictMat_FrictMat_MindlinPhys`` to turn ``en`` into β_n
THORNTON_H = (-6.918798, -16.41105, 146.8049, -796.4559, 2928.711, -7206.864, 11494.29, -11342.18, 6276.757,
              -1489.915)


def thornton_beta(restitution: float) -> float:
    """β_n that YADE 2023.02 derives from ``en`` (Thornton et al. 2013, eqs. B6–B7): the damping
    ratio of its *no-tension* damped Hertz law, c_n = 2 β_n √(m* k_n), k_n = 3/2 k_no √δ."""
    e = restitution
    if e >= 1.0:
        return 0.0
    acc = 0.0
    for h in reversed(THORNTON_H):
        acc = acc * e + h
    return math.sqrt(1.0 / (1.0 - (1.0 + e) ** 2 * math.exp(e * acc)) - 1.0)


def liggghts_beta(restitution: float) -> float:
    """The same damping ratio for LIGGGHTS' ``hertz`` law (attraction allowed at the end of a
    contact): γ_n = −2√(5/6) β √(S_n m*) equals 2 β_n √(m* k_n) with β_n = −√(5/6) β,
    β = ln e / √(ln²e + π²)."""
    if restitution >= 1.0:
        return 0.0
    le = math.log(restitution)
    return -math.sqrt(5.0 / 6.0) * le / math.sqrt(le * le + math.pi * math.pi)


def damped_hertz_impact(restitution: float, radius: float, youngs_modulus: float, poisson_ratio: float,
                        density: float, speed: float, law: str = "liggghts", steps: int = 20000) -> dict[str, float]:
    """Head-on impact of two equal spheres under a damped Hertz law, by RK4 integration of
    m* δ'' = −k_n0 δ^{3/2} − 2 β_n √(2 E* √R* m*) δ^{1/4} δ' until the overlap is back to zero.

    ``law="liggghts"``: LIGGGHTS' ``hertz`` (and numba_dem's) damping, the force may turn
    attractive near the end. ``law="yade"``: YADE 2023.02's Mindlin law with ``en``: Thornton's
    β_n and the total normal force clipped at zero (no attraction), so the spheres fly apart at
    constant speed while still overlapping.

    Returns:
        dict with ``restitution``, ``contact_time`` (s, overlap > 0) and ``peak_overlap`` (m).
    """
    if law not in ("liggghts", "yade"):
        raise ValueError(f"law must be 'liggghts' or 'yade', got {law!r}")
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    mstar = m / 2.0
    reff = radius / 2.0
    e_star, _ = effective_moduli(youngs_modulus, poisson_ratio)
    k0 = 4.0 / 3.0 * e_star * math.sqrt(reff)
    beta_n = liggghts_beta(restitution) if law == "liggghts" else thornton_beta(restitution)
    g0 = 2.0 * beta_n * math.sqrt(2.0 * e_star * math.sqrt(reff) * mstar)
    clip = law == "yade"
    t_c = hertz_contact_time(radius, youngs_modulus, poisson_ratio, density, speed)
    h = 2.0 * t_c / steps

    def acc(d: float, v: float) -> float:
        if d <= 0.0:
            return 0.0
        f = k0 * d**1.5 + g0 * d**0.25 * v
        if clip and f < 0.0:
            f = 0.0
        return -f / mstar

    d, v, t, peak = 0.0, speed, 0.0, 0.0
    while True:
        k1v, k1d = acc(d, v), v
        k2v, k2d = acc(d + 0.5 * h * k1d, v + 0.5 * h * k1v), v + 0.5 * h * k1v
        k3v, k3d = acc(d + 0.5 * h * k2d, v + 0.5 * h * k2v), v + 0.5 * h * k2v
        k4v, k4d = acc(d + h * k3d, v + h * k3v), v + h * k3v
        d += h * (k1d + 2 * k2d + 2 * k3d + k4d) / 6.0
        v += h * (k1v + 2 * k2v + 2 * k3v + k4v) / 6.0
        t += h
        peak = max(peak, d)
        if d <= 0.0:
            return {"restitution": -v / speed, "contact_time": t, "peak_overlap": peak}
        if t > 20.0 * t_c:
            raise RuntimeError("damped Hertz impact did not end")


def damped_hertz_restitution(restitution: float, radius: float, youngs_modulus: float, poisson_ratio: float,
                             density: float, speed: float, law: str = "liggghts",
                             steps: int = 20000) -> tuple[float, float]:
    """(restitution, contact time) of :func:`damped_hertz_impact`."""
    out = damped_hertz_impact(restitution, radius, youngs_modulus, poisson_ratio, density, speed, law, steps)
    return out["restitution"], out["contact_time"]


def _run_script(name: str, params: dict, threads: int, workdir: Path | None, timeout: float) -> dict:
    """Run the packaged YADE script ``name`` on ``params`` (in ``workdir`` or a temporary folder)
    and return its result.json."""
    yade = find_yade()
    with tempfile.TemporaryDirectory(prefix="calibrax-yade-") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        wd = wd.resolve()
        wd.mkdir(parents=True, exist_ok=True)
        p = write_params(wd / "params.json", params)
        run_yade(yade, script_path(name), p, wd, threads, timeout)
        try:
            return json.loads((wd / "result.json").read_text())
        except (OSError, ValueError) as exc:
            raise SimulationFailed(f"unreadable YADE output: {exc}", kind="crash") from exc


def two_sphere_collision(speed: float = 0.5, restitution: float = 1.0, radius: float = 0.9e-3,
                         youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                         steps_per_contact: int = 500, threads: int = 1, workdir: Path | None = None,
                         timeout: float = 300.0) -> dict[str, float]:
    """Head-on impact of two equal spheres at relative speed ``speed`` (m/s), no gravity, in YADE
    with the same contact law and parameter conversion as the shear test.

    Returns:
        dict with ``contact_time`` (s, measured: steps with overlap > 0 × Δt), ``peak_overlap``
        (m), ``hertz_contact_time`` (s, theory for e = 1), ``restitution`` (measured
        −v_rel,out / v_rel,in), ``energy_change`` ((KE_out − KE_in)/KE_in), ``dt`` (s);
        ``damped_restitution`` / ``damped_contact_time`` / ``damped_peak_overlap``: the ODE of
        YADE's own law (:func:`damped_hertz_impact`, ``law="yade"``), ``liggghts_contact_time`` /
        ``liggghts_peak_overlap``: the same ODE for LIGGGHTS' law; ``kno`` / ``kno_theory``
        (N/m^1.5: YADE's normal coefficient and LIGGGHTS' 4/3 E*√R*), ``betan`` / ``betan_thornton``
        (the damping ratio YADE built from ``en`` and Thornton's fit).
    """
    t_c = hertz_contact_time(radius, youngs_modulus, poisson_ratio, density, speed)
    dt = t_c / steps_per_contact
    params = {"speed": speed, "restitution": restitution, "radius": radius, "young": youngs_modulus,
              "poisson": poisson_ratio, "density": density, "dt": dt, "gap": 0.1 * speed * t_c,
              "max_steps": 20 * steps_per_contact}
    out = _run_script("two_spheres.py", params, threads, workdir, timeout)
    own = damped_hertz_impact(restitution, radius, youngs_modulus, poisson_ratio, density, speed, law="yade")
    lig = damped_hertz_impact(restitution, radius, youngs_modulus, poisson_ratio, density, speed, law="liggghts")
    e_star, _ = effective_moduli(youngs_modulus, poisson_ratio)
    return {"contact_time": out["contact_steps"] * dt, "hertz_contact_time": t_c, "restitution": out["v_out"] / speed,
            "peak_overlap": out["peak_overlap"],
            "energy_change": (out["ke1"] - out["ke0"]) / out["ke0"], "dt": dt,
            "damped_restitution": own["restitution"], "damped_contact_time": own["contact_time"],
            "damped_peak_overlap": own["peak_overlap"], "liggghts_contact_time": lig["contact_time"],
            "liggghts_peak_overlap": lig["peak_overlap"],
            "kno": out["kno"], "kno_theory": 4.0 / 3.0 * e_star * math.sqrt(radius / 2.0),
            "betan": out["betan"], "betan_thornton": thornton_beta(restitution)}


def _rest_overlap(radius: float, mass: float, e_star: float, g: float) -> float:
    return (mass * g / (4.0 / 3.0 * e_star * math.sqrt(radius))) ** (2.0 / 3.0)


def _sphere_on_base(*, radius: float, youngs_modulus: float, poisson_ratio: float, density: float,
                    restitution: float, friction: float, rolling_friction: float, g: float, dt: float,
                    velocity: tuple[float, float, float], spin: tuple[float, float, float], nsteps: int,
                    every: int, threads: int, workdir: Path | None, timeout: float) -> np.ndarray:
    """One sphere resting (at its static overlap) on a base facet at z = 0, with the shear test's
    facet material and contact parameters (:func:`calibrax_yade.contact.contact_params` of a spec
    with this material); rows (step, vx, ωx)."""
    material = Material(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, restitution=restitution,
                        sliding_friction=friction, rolling_friction=rolling_friction, density=density)
    cp = contact_params(ShearCellSpec(material=material, radius=radius))
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    z0 = radius - _rest_overlap(radius, m, cp.e_star, g)  # the facet material gives LIGGGHTS' wall k_n
    params = {"radius": radius, "young": cp.young, "poisson": cp.poisson, "facet_young": cp.facet_young,
              "facet_poisson": cp.facet_poisson, "density": density, "restitution": cp.restitution,
              "shear_restitution": cp.shear_restitution, "friction": friction, "krot": cp.krot, "eta": cp.eta,
              "gravity": g, "dt": dt, "z0": z0, "velocity": list(velocity), "spin": list(spin),
              "nsteps": int(nsteps), "every": int(every), "half_width": 0.1}
    out = _run_script("sphere_on_base.py", params, threads, workdir, timeout)
    return np.asarray(out["rows"], dtype=float)


def sliding_on_base(friction: float = 0.5, speed: float = 0.5, radius: float = 0.9e-3,
                    youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                    restitution: float = 0.3, g: float = 9.81, dt: float = 1.0e-6, threads: int = 1,
                    workdir: Path | None = None, timeout: float = 300.0) -> dict[str, float]:
    """A sphere launched without spin along a flat base facet of friction ``friction`` (no rolling
    resistance), as ``calibrax_numba_dem.verification.sliding_on_base``: while it slides, Coulomb
    friction decelerates it at μs·g. Returns ``deceleration`` (m/s², least-squares slope of v(t)
    over the middle 80 % of the sliding phase), ``expected`` (μs·g) and ``sliding_time`` (s,
    theory 2 v0 / (7 μs g))."""
    t_slide = sliding_time(speed, friction, g)
    every = max(1, int(t_slide / dt / 200))
    rows = _sphere_on_base(radius=radius, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, density=density,
                           restitution=restitution, friction=friction, rolling_friction=0.0, g=g, dt=dt,
                           velocity=(speed, 0.0, 0.0), spin=(0.0, 0.0, 0.0), nsteps=int(math.ceil(t_slide / dt)),
                           every=every, threads=threads, workdir=workdir, timeout=timeout)
    return sliding_deceleration(rows[:, 0] * dt, rows[:, 1], speed, friction, g)


def rolling_resistance(rolling_friction: float = 0.5, spin: float = 30.0, radius: float = 0.9e-3,
                       youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                       restitution: float = 0.3, g: float = 9.81, dt: float = 1.0e-6, threads: int = 1,
                       workdir: Path | None = None, timeout: float = 300.0) -> dict[str, float]:
    """A sphere spinning about a horizontal axis on a base facet without sliding friction, with
    the shear test's rolling parameters (constant k_r, η = μr/2), as
    ``calibrax_numba_dem.verification.rolling_resistance``. LIGGGHTS' EPSD2 torque on a wall
    saturates at μr·r·m·g; YADE's limit is η·R_mean·F_n with R_mean = (2r + r)/2 on a facet, i.e.
    0.75 μr r m g (see :mod:`calibrax_yade.contact`). Returns ``torque`` (N·m, I·|dω/dt| over the
    saturated phase), ``expected`` (μr r m g, LIGGGHTS' limit), ``peak_torque`` (N·m, largest
    I·|Δω/Δt| between samples) and ``yade_limit`` (N·m, 0.75 μr r m g)."""
    inertia, expected, t_stop = rolling_stop(radius, density, rolling_friction, spin, g)
    nsteps = int(0.8 * t_stop / dt)
    every = max(1, nsteps // 400)
    rows = _sphere_on_base(radius=radius, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, density=density,
                           restitution=restitution, friction=0.0, rolling_friction=rolling_friction, g=g, dt=dt,
                           velocity=(0.0, 0.0, 0.0), spin=(spin, 0.0, 0.0), nsteps=nsteps, every=every,
                           threads=threads, workdir=workdir, timeout=timeout)
    t = rows[:, 0] * dt
    w = rows[:, 2]
    torques = -np.diff(w) / np.diff(t) * inertia
    sel = t > 0.2 * t[-1]
    slope = np.polyfit(t[sel], w[sel], 1)[0]
    return {"torque": -float(slope) * inertia, "expected": expected, "peak_torque": float(np.max(np.abs(torques))),
            "yade_limit": 0.75 * expected}


class YadeVerification(FunctionVerification):
    """yade's analytic checks for the crosscheck (:class:`calibrax.core.sheartest.verification.Verification`)."""

    name = "yade"
    known_differences = KNOWN_DIFFERENCES
    collision = staticmethod(two_sphere_collision)
    sliding = staticmethod(sliding_on_base)
    rolling = staticmethod(rolling_resistance)
