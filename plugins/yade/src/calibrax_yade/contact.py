"""Convert the spec's material into YADE ``Ip2_FrictMat_FrictMat_MindlinPhys`` parameters that
reproduce LIGGGHTS' ``model hertz tangential history rolling_friction epsd2`` (numba_dem's law) as
closely as YADE 2023.02 allows.

The rule: particle–particle stiffness and damping are LIGGGHTS' exactly; facets get a fictitious
material whose k_no and k_so equal LIGGGHTS' wall values; what YADE cannot match (its clipped,
Thornton-fitted normal damping, no tangential dashpot, a constant rolling stiffness, its rolling
limit on unequal spheres and facets, no twisting) is listed, numbered, with the measurements behind
it, in docs/explanation/yade-contact-law.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from calibrax.core.sheartest import ShearCellSpec

__all__ = ["YadeContactParams", "contact_params", "facet_material", "effective_moduli", "hertz_overlap",
           "SHEAR_RESTITUTION"]

#: ``es`` given to ``Ip2_FrictMat_FrictMat_MindlinPhys``: 1 makes β_s = 0, i.e. no tangential dashpot
#: (difference 2 of docs/explanation/yade-contact-law.md: YADE's unbounded tangential dashpot destabilises a loaded bed)
SHEAR_RESTITUTION = 1.0


def effective_moduli(youngs_modulus: float, poisson_ratio: float) -> tuple[float, float]:
    """(E*, G*) of two bodies of the same material, Pa (LIGGGHTS' definitions)."""
    e, nu = youngs_modulus, poisson_ratio
    return e / (2.0 * (1.0 - nu * nu)), e / (4.0 * (2.0 - nu) * (1.0 + nu))


def hertz_overlap(force: float, e_star: float, reff: float) -> float:
    """Overlap δ (m) of a Hertz contact carrying ``force`` (N): F = 4/3 E* √R* δ^{3/2}."""
    return (force / (4.0 / 3.0 * e_star * math.sqrt(reff))) ** (2.0 / 3.0)


def facet_material(youngs_modulus: float, poisson_ratio: float) -> tuple[float, float]:
    """(E_w, ν_w) of the facets' fictitious material so that a YADE sphere–facet contact
    (R = 2r/3) has LIGGGHTS' wall stiffnesses k_n = 4/3 E*√(rδ), k_t = 8 G*√(rδ).

    Conditions: E_y √(2/3) = E* and G_y √(2/3) = G* with YADE 2023.02's pair moduli
    1/E_y = (1−ν²)/E + (1−ν_w²)/E_w and 1/G_y = (2−ν)/G + (2−ν_w)/G_w. Both hold with
    ν_w = ν and E_w = E / (2√(2/3) − 1) ≈ 1.58 E.
    """
    return youngs_modulus / (2.0 * math.sqrt(2.0 / 3.0) - 1.0), poisson_ratio


@dataclass(frozen=True)
class YadeContactParams:
    """Numbers handed to the YADE script (SI units).

    Attributes:
        young, poisson: the particles' E (Pa) and ν, as given.
        facet_young, facet_poisson: the facets' fictitious E_w (Pa) and ν_w (see :func:`facet_material`).
        restitution: e, passed as ``en`` to the Ip2 functor.
        shear_restitution: passed as ``es`` (1: no tangential dashpot, see :data:`SHEAR_RESTITUTION`).
        krot: constant rolling stiffness k_r, N·m/rad. eta: η = μr/2 (dimensionless).
        e_star: E* (Pa), for the servo's bed-stiffness estimate.
    """

    young: float
    poisson: float
    facet_young: float
    facet_poisson: float
    restitution: float
    shear_restitution: float
    krot: float
    eta: float
    e_star: float


def contact_params(spec: ShearCellSpec) -> YadeContactParams:
    """The YADE contact parameters of ``spec`` (the mapping: docs/explanation/yade-contact-law.md)."""
    m = spec.material
    e_star, g_star = effective_moduli(m.youngs_modulus, m.poisson_ratio)
    ew, nuw = facet_material(m.youngs_modulus, m.poisson_ratio)
    r = spec.radius
    reff = r / 2.0
    f_ref = spec.procedure.preshear_stress * (2.0 * r) ** 2
    delta = hertz_overlap(f_ref, e_star, reff)
    kt = 8.0 * g_star * math.sqrt(reff * delta)
    krot = kt * reff**2
    return YadeContactParams(young=m.youngs_modulus, poisson=m.poisson_ratio, facet_young=ew, facet_poisson=nuw,
                             restitution=m.restitution, shear_restitution=SHEAR_RESTITUTION, krot=krot,
                             eta=0.5 * m.rolling_friction, e_star=e_star)
