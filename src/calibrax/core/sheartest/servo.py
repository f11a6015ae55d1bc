"""Gains of the FT4 head's stress servo, shared by the backends that run it (numba_dem, LIGGGHTS;
YADE's script runs under the system Python and carries its own copy).

The head is a rigid body of mass M under the target load with a damper c on v − v_ref, v_ref being
v low-passed over τ_ref (see ``calibrax_numba_dem.servo`` for the law and why its gains are small).
"""

from __future__ import annotations

import math

__all__ = ["HEAD_MASS_FRACTION", "TAU_REF_PERIODS", "servo_gains"]

#: the servo's head mass as a fraction of the bed's mass
HEAD_MASS_FRACTION = 0.25
#: τ_ref in head–bed periods
TAU_REF_PERIODS = 1.0


def servo_gains(stress: float, area: float, radius: float, e_star: float, bed_height: float,
                bed_mass: float, damping_ratio: float = 1.0, mass_fraction: float = HEAD_MASS_FRACTION,
                tau_periods: float = TAU_REF_PERIODS) -> tuple[float, float, float]:
    """Servo mass (kg), damping (N·s/m) and v_ref time constant (s) for a bed under ``stress`` (Pa).

    The bed's vertical stiffness is estimated as columns of Hertz contacts: a contact carrying
    f = σ (2R)² has tangent stiffness k_c = 2E*√(R* δ) (R* = R/2), and A/(2R)² columns of
    H/(2R) contacts in series give k_bed = k_c A / (2R H) (A: head area, m²; R: particle radius,
    m; E*: Pa; H: bed height, m). The head's mass is ``mass_fraction`` of the bed's mass (kg), its
    damping ``damping_ratio`` of critical on k_bed, τ_ref ``tau_periods`` head–bed periods.
    """
    f = stress * (2.0 * radius) ** 2
    reff = radius / 2.0
    delta = (f / (4.0 / 3.0 * e_star * math.sqrt(reff))) ** (2.0 / 3.0)
    k_c = 2.0 * e_star * math.sqrt(reff * delta)
    k_bed = k_c * area / (2.0 * radius * bed_height)
    mass = mass_fraction * bed_mass
    damp = 2.0 * damping_ratio * math.sqrt(k_bed * mass)
    period = 2.0 * math.pi * math.sqrt(mass / k_bed)
    return mass, damp, tau_periods * period
