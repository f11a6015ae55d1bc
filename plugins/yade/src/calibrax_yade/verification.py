"""Verification of the YADE contact law against Hertz theory, run with the real ``yade`` binary.

Same signature and return keys as ``calibrax_numba_dem.verification.two_sphere_collision``, so a
cross-check can compare the backends; extra keys carry the theory of the damped case and the
contact stiffness YADE built from the converted parameters.
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

from calibrax.errors import SimulationFailed

from .contact import effective_moduli
from .runner import find_yade, run_yade, script_path, write_params

__all__ = ["hertz_contact_time", "damped_hertz_restitution", "two_sphere_collision"]


def hertz_contact_time(radius: float, youngs_modulus: float, poisson_ratio: float, density: float,
                       speed: float) -> float:
    """Duration of an elastic Hertz impact of two equal spheres at relative speed ``speed`` (m/s):
    t_c = 2.87 (m*² / (R* E*² v))^(1/5), s."""
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    e_star, _ = effective_moduli(youngs_modulus, poisson_ratio)
    return 2.87 * ((m / 2.0) ** 2 / (radius / 2.0 * e_star**2 * speed)) ** 0.2


def damped_hertz_restitution(restitution: float, radius: float, youngs_modulus: float, poisson_ratio: float,
                             density: float, speed: float, clip: bool = False, steps: int = 20000) -> tuple[float, float]:
    """(restitution, contact time) of the damped Hertz law of LIGGGHTS' ``hertz`` model for two
    equal spheres, by RK4 integration of m* δ'' = −k_n0 δ^{3/2} − γ_n0 δ^{1/4} δ'.

    k_n0 = 4/3 E* √R*, γ_n0 = −2√(5/6) β √(2 E* √R* m*), β = ln e/√(ln²e + π²). ``clip``: the
    force may not turn attractive (YADE's Mindlin law), the contact then ends when it reaches 0.
    """
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    mstar = m / 2.0
    reff = radius / 2.0
    e_star, _ = effective_moduli(youngs_modulus, poisson_ratio)
    k0 = 4.0 / 3.0 * e_star * math.sqrt(reff)
    if restitution >= 1.0:
        beta = 0.0
    else:
        le = math.log(restitution)
        beta = le / math.sqrt(le * le + math.pi * math.pi)
    g0 = -2.0 * math.sqrt(5.0 / 6.0) * beta * math.sqrt(2.0 * e_star * math.sqrt(reff) * mstar)
    t_c = hertz_contact_time(radius, youngs_modulus, poisson_ratio, density, speed)
    h = 2.0 * t_c / steps

    def acc(d: float, v: float) -> float:
        if d <= 0.0:
            return 0.0
        f = k0 * d**1.5 + g0 * d**0.25 * v
        if clip and f < 0.0:
            f = 0.0
        return -f / mstar

    d, v, t = 0.0, speed, 0.0
    while True:
        k1v, k1d = acc(d, v), v
        k2v, k2d = acc(d + 0.5 * h * k1d, v + 0.5 * h * k1v), v + 0.5 * h * k1v
        k3v, k3d = acc(d + 0.5 * h * k2d, v + 0.5 * h * k2v), v + 0.5 * h * k2v
        k4v, k4d = acc(d + h * k3d, v + h * k3v), v + h * k3v
        d += h * (k1d + 2 * k2d + 2 * k3d + k4d) / 6.0
        v += h * (k1v + 2 * k2v + 2 * k3v + k4v) / 6.0
        t += h
        if d <= 0.0 or (clip and v < 0.0 and acc(d, v) == 0.0):
            return -v / speed, t
        if t > 20.0 * t_c:
            raise RuntimeError("damped Hertz impact did not end")


def two_sphere_collision(speed: float = 0.5, restitution: float = 1.0, radius: float = 0.9e-3,
                         youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                         steps_per_contact: int = 500, threads: int = 1, workdir: Path | None = None,
                         timeout: float = 300.0) -> dict[str, float]:
    """Head-on impact of two equal spheres at relative speed ``speed`` (m/s), no gravity, in YADE
    with the same contact law and parameter conversion as the shear test.

    Returns:
        dict with ``contact_time`` (s, measured), ``hertz_contact_time`` (s, theory for e = 1),
        ``restitution`` (measured −v_rel,out / v_rel,in), ``energy_change`` ((KE_out − KE_in)/KE_in),
        ``dt`` (s), and ``damped_restitution`` / ``damped_contact_time`` (the damped Hertz ODE of
        LIGGGHTS' ``hertz`` law, see :func:`damped_hertz_restitution`), ``kno`` / ``kno_theory``
        (N/m^1.5: YADE's normal coefficient and LIGGGHTS' 4/3 E*√R*).
    """
    t_c = hertz_contact_time(radius, youngs_modulus, poisson_ratio, density, speed)
    dt = t_c / steps_per_contact
    params = {"speed": speed, "restitution": restitution, "radius": radius, "young": youngs_modulus,
              "poisson": poisson_ratio, "density": density, "dt": dt, "gap": 0.1 * speed * t_c,
              "max_steps": 20 * steps_per_contact}
    yade = find_yade()
    with tempfile.TemporaryDirectory(prefix="calibrax-yade-") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        wd = wd.resolve()
        wd.mkdir(parents=True, exist_ok=True)
        p = write_params(wd / "params.json", params)
        run_yade(yade, script_path("two_spheres.py"), p, wd, threads, timeout)
        try:
            out = json.loads((wd / "result.json").read_text())
        except (OSError, ValueError) as exc:
            raise SimulationFailed(f"unreadable YADE output: {exc}", kind="crash") from exc
    e_d, t_d = damped_hertz_restitution(restitution, radius, youngs_modulus, poisson_ratio, density, speed)
    e_star, _ = effective_moduli(youngs_modulus, poisson_ratio)
    return {"contact_time": out["contact_steps"] * dt, "hertz_contact_time": t_c, "restitution": out["v_out"] / speed,
            "energy_change": (out["ke1"] - out["ke0"]) / out["ke0"], "dt": dt,
            "damped_restitution": e_d, "damped_contact_time": t_d,
            "kno": out["kno"], "kno_theory": 4.0 / 3.0 * e_star * math.sqrt(radius / 2.0)}
