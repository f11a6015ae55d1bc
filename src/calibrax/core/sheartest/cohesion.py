"""Cohesion in physical units: the Bond number, and the simplified-JKR (SJKR) contact law that
numba_dem and LIGGGHTS (``cohesion sjkr``) share. SI units.

**The law.** SJKR adds an attraction k·A to the Hertz repulsion of a contact, k the cohesion
energy density (J/m³) and A the area of the contact circle. LIGGGHTS computes A exactly from the
two spheres' intersection; to first order in the overlap δ it is A = 2π R* δ for two spheres
(R* = R_i R_j / (R_i + R_j)) and 2π R δ for a sphere on a wall, which is what numba_dem uses (the
second-order difference is δ/(4R*) of A, below 10⁻³ at the shear test's overlaps). The net normal
force F(δ) = 4/3 E* √R* δ^(3/2) − 2π k R* δ is most attractive at δ* = π² k² R* / E*², where the
force needed to pull the contact apart quasi-statically is

    F_pull-off = 2/3 π³ k³ R*² / E*²,        E* = E / (2 (1 − ν²)).

Under compression the friction limit of both engines is μ·|F|, the net force: cohesion lowers a
compressed contact's friction limit and adds strength only through the contacts it holds in
tension and the looser structures it lets survive.

**The Bond number** is the pull-off force of two particles of the nominal radius over the mean
contact force that a stress σ puts on them, ⟨F⟩ = π d² σ / (φ Z) (the stress–force relation of a
random sphere packing, Rothenburg and Bathurst 1989), with the nominal solid fraction φ = 0.6 and
coordination number Z = 5 of a frictional packing under load. It is taken at a fixed reference
stress, :data:`BOND_REFERENCE_STRESS` = 15 kPa (the reference paper's preshear and the FT4's
standard 15 kPa test), whatever procedure the cell runs, so that a Bond number names one powder:
at a lower stress σ the same powder's contacts feel (15 kPa / σ) times more of it, five times at
the FT4's 3 kPa standard preshear (procedure ``ft4_3kpa``), fifteen times at the compressibility
ramp's first 1 kPa. Cohesion begins to change a sphere
packing's shear strength near Bo = 1 (Singh, Magnanimo, Saitoh and Luding, 2014); at Bo ≤ 0.1 a
powder flows freely. For the reference paper's material (E = 25 GPa, ν = 0.25, R = 0.9 mm) at
15 kPa, Bo = 1 is k ≈ 1.3·10⁸ J/m³; k = 3·10⁷ J/m³ is Bo ≈ 0.012.
"""

from __future__ import annotations

import math

#: the nominal solid fraction and coordination number of the Bond number's mean contact force
BOND_SOLID_FRACTION = 0.6
BOND_COORDINATION = 5.0
#: the normal stress, Pa, whose mean contact force the Bond number compares the pull-off force
#: with, for every procedure (a Bond number taken at each procedure's own preshear would make
#: the same Bo a 5× weaker powder in the FT4's 3 kPa test than in its 15 kPa one)
BOND_REFERENCE_STRESS = 15.0e3


def effective_modulus(youngs_modulus: float, poisson_ratio: float) -> float:
    """E* = E / (2 (1 − ν²)) of two particles of the same material, Pa."""
    return youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))


def sjkr_pull_off_force(energy_density: float, effective_radius: float, e_star: float) -> float:
    """The force, N, that pulls an SJKR contact apart quasi-statically: 2/3 π³ k³ R*² / E*²
    (``energy_density`` k in J/m³, ``effective_radius`` R* in m: R/2 for two equal spheres, R for a
    sphere on a wall; ``e_star`` in Pa)."""
    return 2.0 / 3.0 * math.pi**3 * energy_density**3 * effective_radius**2 / e_star**2


def sjkr_pull_off_overlap(energy_density: float, effective_radius: float, e_star: float) -> float:
    """The overlap, m, at which an SJKR contact is most attractive: π² k² R* / E*²."""
    return math.pi**2 * energy_density**2 * effective_radius / e_star**2


def sjkr_energy_density(pull_off_force: float, effective_radius: float, e_star: float) -> float:
    """The SJKR cohesion energy density, J/m³, whose pull-off force is ``pull_off_force`` (N): the
    inverse of :func:`sjkr_pull_off_force`."""
    return (1.5 * pull_off_force * e_star**2 / (math.pi**3 * effective_radius**2)) ** (1.0 / 3.0)


def mean_contact_force(radius: float, stress: float) -> float:
    """⟨F⟩ = π d² σ / (φ Z), N: the mean contact force a stress ``stress`` (Pa) puts on particles
    of radius ``radius`` (m) in a packing of the nominal φ and Z."""
    return math.pi * (2.0 * radius) ** 2 * stress / (BOND_SOLID_FRACTION * BOND_COORDINATION)


def bond_number_energy_density(bond_number: float, radius: float, youngs_modulus: float, poisson_ratio: float,
                               stress: float) -> float:
    """The SJKR cohesion energy density, J/m³, at which two particles of radius ``radius`` (m) have
    a pull-off force ``bond_number`` times the mean contact force at ``stress`` (Pa)."""
    if bond_number <= 0.0:
        return 0.0
    return sjkr_energy_density(bond_number * mean_contact_force(radius, stress), 0.5 * radius,
                               effective_modulus(youngs_modulus, poisson_ratio))


def energy_density_bond_number(energy_density: float, radius: float, youngs_modulus: float, poisson_ratio: float,
                               stress: float) -> float:
    """The Bond number of an SJKR cohesion energy density (J/m³): the inverse of
    :func:`bond_number_energy_density`."""
    force = sjkr_pull_off_force(energy_density, 0.5 * radius, effective_modulus(youngs_modulus, poisson_ratio))
    return force / mean_contact_force(radius, stress)


__all__ = ["BOND_SOLID_FRACTION", "BOND_COORDINATION", "effective_modulus", "sjkr_pull_off_force",
           "sjkr_pull_off_overlap", "sjkr_energy_density", "mean_contact_force", "bond_number_energy_density",
           "energy_density_bond_number"]
