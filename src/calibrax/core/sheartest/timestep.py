"""The critical time step of the contact law (the paper's eq. (1)): what every backend's time step
is a fraction of (:attr:`calibrax.core.sheartest.spec.ShearCellSpec.time_step`)."""

from __future__ import annotations

import math


def critical_time_step(radius: float, density: float, reduced_modulus: float, stress: float) -> float:
    """The paper's eq. (1): Δt_crit = R (4/3)^(2/3) π^(1/3) √ρ σ0^(−1/6) Ẽ^(−1/3), s.

    Args:
        radius: R, m. density: ρ, kg/m³. reduced_modulus: Ẽ = E/(1−ν²), Pa. stress: σ0, Pa.
    """
    return radius * (4.0 / 3.0) ** (2.0 / 3.0) * math.pi ** (1.0 / 3.0) * math.sqrt(density) \
        * stress ** (-1.0 / 6.0) * reduced_modulus ** (-1.0 / 3.0)
