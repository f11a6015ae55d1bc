"""Analytic references the backends' verification cases are checked against (SI units).

Every backend's ``verification`` module runs the same cases on its own engine and compares with
these: the Hertz contact time of a head-on impact, the deceleration of a sphere sliding on a flat
base, and the rolling torque that stops a sphere spinning on one. Shared here so that "the theory" means one thing for all backends.
"""

from __future__ import annotations

import math

import numpy as np


def hertz_contact_time(radius: float, youngs_modulus: float, poisson_ratio: float, density: float,
                       speed: float) -> float:
    """Duration of an elastic Hertz impact of two equal spheres at relative speed ``speed`` (m/s):
    t_c = 2.87 (m*² / (R* E*² v))^(1/5), s, with m* = m/2, R* = R/2, E* = E / (2(1 − ν²))."""
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    e_star = youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))
    return 2.87 * ((m / 2.0) ** 2 / (radius / 2.0 * e_star**2 * speed)) ** 0.2


def sliding_time(speed: float, friction: float, g: float = 9.81) -> float:
    """Time, s, for a sphere launched at ``speed`` (m/s) without spin on a base of friction
    ``friction`` to reach rolling without slip: 2 v0 / (7 μs g)."""
    return 2.0 * speed / (7.0 * friction * g)


def sliding_deceleration(t: np.ndarray, v: np.ndarray, speed: float, friction: float,
                         g: float = 9.81) -> dict[str, float]:
    """Measured and expected deceleration of a sliding sphere from its speed history ``v`` (m/s)
    at times ``t`` (s), both (n,): the least-squares slope over the middle 80 % of the sliding
    phase. Returns ``deceleration`` (m/s²), ``expected`` (μs g) and ``sliding_time`` (s)."""
    t_slide = sliding_time(speed, friction, g)
    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    sel = (t > 0.1 * t_slide) & (t < 0.9 * t_slide)
    slope = np.polyfit(t[sel], v[sel], 1)[0]
    return {"deceleration": -float(slope), "expected": friction * g, "sliding_time": t_slide}


def rolling_stop(radius: float, density: float, rolling_friction: float, spin: float,
                 g: float = 9.81) -> tuple[float, float, float]:
    """A sphere (radius m, density kg/m³) spinning at ``spin`` rad/s on a flat base under EPSD2
    rolling resistance: (its moment of inertia 0.4 m r², kg·m²; the saturated rolling torque
    μr r m g, N·m; the time it takes that torque to stop it, I ω / (μr r m g), s)."""
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    inertia = 0.4 * m * radius**2
    torque = rolling_friction * radius * m * g
    return inertia, torque, spin * inertia / torque
