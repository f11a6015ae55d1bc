"""The periodic sector: 1/k of the FT4 cell with rotationally periodic faces.

The cell is n-fold symmetric (an axisymmetric vessel, n blades and n ribs), so 1/k of it (k
divides n) holds the same physics: a particle leaving the wedge 0 ≤ θ < 2π/k through one face
enters through the other, rotated by 2π/k, and a contact across a face sees its partner's image
rotated by 2π/k. The head's force and torque are k times the sector's.

Near the axis the wedge is too narrow for a particle not to meet its own image, so the sector
keeps a frictionless core there: a cylinder of radius :func:`core_radius` that holds every
particle's centre at least (r_max + δ) / sin(π/k) from the axis, DEM-Engine's rule for its
cylindrical periodicity (r_min = (b + δ)/sin(Δθ/2), b a particle's bounding radius and δ the
contact margin; https://github.com/projectchrono/DEM-Engine). Its effect on the test is measured
in ``docs/explanation/sector.md``. Units: m, rad.
"""

from __future__ import annotations

import math

#: the contact margin δ of the core's rule, as a fraction of the smallest particle's radius: the
#: neighbour-list skin of numba_dem (calibrax_numba_dem.engine.DEMSystem), so that no particle
#: lists its own image as a neighbour
SECTOR_MARGIN_FRACTION = 0.3


def sector_angle(sector: int) -> float:
    """The wedge's opening 2π/k, rad, of a sector of 1/``sector`` of the cell."""
    return 2.0 * math.pi / sector


def core_radius(sector: int, r_max: float, r_min: float) -> float:
    """Radius of the frictionless core of a 1/``sector`` sector, m: (r_max + δ)/sin(π/k) − r_max
    with δ = SECTOR_MARGIN_FRACTION · r_min, so that a particle's centre stays (r_max + δ)/sin(π/k)
    from the axis; 0 for the full cell (``sector`` 1).

    Args:
        sector: k ≥ 1. r_max, r_min: the largest and smallest particle radius, m.
    """
    if sector <= 1:
        return 0.0
    return (r_max + SECTOR_MARGIN_FRACTION * r_min) / math.sin(math.pi / sector) - r_max


def bed_cross_section(sector: int, vessel_radius: float, core: float) -> float:
    """The horizontal area the particles fill, m²: the vessel's π R², or the sector's
    π (R² − r_core²)/k (the core's share left out)."""
    return math.pi * (vessel_radius**2 - core**2) / sector


def sector_width(sector: int, head_radius: float, diameter: float) -> float:
    """The wedge's arc at two thirds of the head's radius (where τ is read, and the inertial
    number's shear rate taken), in particle diameters: 2π/k · ⅔ R_head / d. A sector's bias on the
    mean peak τ/σ against the full cell was +0.21 at 4.0 diameters and +0.045 at 5.4–8.0
    (docs/explanation/sector.md)."""
    return sector_angle(sector) * (2.0 / 3.0) * head_radius / diameter
