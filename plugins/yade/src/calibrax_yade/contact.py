"""Convert the spec's material into YADE ``Ip2_FrictMat_FrictMat_MindlinPhys`` parameters that
reproduce LIGGGHTS' ``model hertz tangential history rolling_friction epsd2`` as closely as YADE
2023.02 allows.

What YADE computes (pkg/dem/HertzMindlin.cpp), for materials a, b and a contact of "radii" Da, Db:

* E_y = E_a E_b / ((1−ν_a²) E_b + (1−ν_b²) E_a); 1/G_y = (2−ν_a)/G_a + (2−ν_b)/G_b
  (measured on the installed 2023.02a: its k_so is 8 G_y √R, not the trunk source's
  2√(4R) (G_a+G_b)/2 / (2 − (ν_a+ν_b)/2); both agree for a single material);
  R = Da Db/(Da + Db); R_mean = (Da + Db)/2;
* F_n = k_no δ^{3/2}, k_no = 4/3 E_y √R; k_s = k_so √δ, k_so = 8 G_y √R;
* with ``en`` (measured on 2023.02a, as in its source): c_n = 2 β_n √(m̄ k_n), k_n = 3/2 k_no √δ,
  β_n from Thornton et al. (2013)'s fit of e for a no-tension law, and the damped normal force
  clipped at zero; c_s = 2 β_s √(m̄ k_s), β_s from ``es`` by the same fit (β_s = 0 for es = 1;
  m̄ = m of the particle against a fixed body), added to the elastic shear force only while the
  contact sticks and not bounded by the Coulomb limit. The older
  α = −2√(5/6) ln e/√(ln²e + π²) √(2 E_y √R) form (LIGGGHTS' dashpot) is gone;
* rolling (``includeMoment``): M_b −= k_r Δθ_bend, |M_b| ≤ η R_mean |F_n|; twisting k_tw.

LIGGGHTS (and numba_dem): E* = E/(2(1−ν²)), G* = E/(4(2−ν)(1+ν)), k_n = 4/3 E* √(R*δ),
k_t = 8 G* √(R*δ), γ_{n,t} = −2√(5/6) β √(S_{n,t} m*), S_n = 2E*√(R*δ), S_t = k_t,
β = ln e/√(ln²e + π²); EPSD2: k_r = k_t R*² (LIGGGHTS 3.8's rolling_model_epsd2.h; the original
EPSD's 2.25 k_n μr² R*² is 2.3× softer at μr = 0.5), |M_r| ≤ μr R* |F_n|; walls: R* = r, m* = m.

Particle–particle (Da, Db = r_i, r_j): with the particles' own E and ν, k_no, k_so and c_n are
exactly LIGGGHTS' (E_y = E*, G_y = G*).

Particle–facet: YADE's facet contact has Da = 2r, Db = r, so R = 2r/3 instead of LIGGGHTS' wall
R* = r. The facets therefore get a *fictitious* material (E_w, ν_w), solved so that k_no and k_so
of a facet contact equal LIGGGHTS' wall values (c_n then follows exactly, since α ∝ √(E_y √R)).

Remaining differences (also in the README):

1. damping: with ``en = es = e`` YADE's β_n = β_s = Thornton's β(e) > LIGGGHTS' −√(5/6) β
   (0.454 against 0.327 at e = 0.3), and its damped normal force never turns attractive. The
   restitution is the same, but a damped impact lasts longer and goes less deep (two spheres at
   e = 0.3: contact time +3.7 %, peak overlap −11 %; ``verification.damped_hertz_impact``). YADE
   2023.02 has no unclipped law: LIGGGHTS' dashpot (``betan = −√(5/6) β``) with the clipping
   would give e = 0.40 for e = 0.3, so ``en`` is kept (the calibrated parameter is e);
2. (see 1) the clipping; and **no tangential dashpot** (``es = 1``, β_s = 0; LIGGGHTS:
   γ_t = −2√(5/6) β √(k_t m*)). YADE's tangential dashpot is not bounded by the Coulomb limit
   and is switched off while the contact slides; with β_s = β_n (``es = e``, 0.454 at e = 0.3),
   and still with LIGGGHTS' 0.327, it made a bed loaded at the preshear stress unstable at the
   spec's time step (0.2 Δt_crit): particles spinning, ~30 % of the contacts sliding and ~20 %
   at their rolling limit throughout the bed, the head's load relaxing by 80 % within 2 ms when
   held still, and the head sinking steadily at constant σ (it never met the consolidation's stop
   rule). β_s ≤ 0.2 or half the time step cured it; β_s = 0 is used (see :data:`SHEAR_RESTITUTION`);
3. rolling stiffness: YADE's k_r is a constant, set here to EPSD2's k_r at the Hertz overlap of a
   particle pair carrying σ_pre (2r)² (the preshear stress), instead of following δ;
4. rolling limit: η = μr/2 makes η R_mean = μr R* exact for equal spheres; for unequal ones YADE's
   limit is (r_i + r_j)²/(4 r_i r_j) ≥ 1 times LIGGGHTS'; on facets it is 0.75 μr r
   (LIGGGHTS: μr r). YADE has one η for every contact, so a lateral wall without friction would
   keep it; the script takes it off that wall's contacts (numba_dem and LIGGGHTS have none there,
   and with it the vessel carried a fifth of the head's torque);
5. no twisting resistance in either (k_tw = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from calibrax.core.sheartest import ShearCellSpec

__all__ = ["YadeContactParams", "contact_params", "facet_material", "effective_moduli", "hertz_overlap",
           "SHEAR_RESTITUTION"]

#: ``es`` given to ``Ip2_FrictMat_FrictMat_MindlinPhys``: 1 makes β_s = 0, i.e. no tangential dashpot
#: (difference 2 in the module docstring: YADE's unbounded tangential dashpot destabilises a loaded bed)
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
    """The YADE contact parameters of ``spec`` (see the module docstring for the mapping)."""
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
