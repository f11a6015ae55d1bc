"""Physics of the cell that every backend and every result reads the same way (the critical time
step is :mod:`calibrax.core.sheartest.timestep`'s): τ from the head's torque, the inertial number, what the base can hold and whether the bed
slid on it, whether a yield locus looks physical, and whether the head's rim can wedge particles against a
frictional wall."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from calibrax.core.sheartest.yieldlocus import YieldLocus

if TYPE_CHECKING:
    from calibrax.core.sheartest.steps import StepRecord
    from calibrax.core.sheartest.spec import ShearCellSpec

def shear_stress_from_torque(torque: np.ndarray | float, head_radius: float) -> np.ndarray | float:
    """τ = 3T / (2π R_head³), Pa, from the head torque T (N·m): uniform τ over the head's disc."""
    return 3.0 * np.asarray(torque) / (2.0 * math.pi * head_radius**3)


def inertial_number(spec: ShearCellSpec, normal_stress: float) -> float:
    """Inertial number I = γ̇ d / √(σ/ρ) of a shear step (I < 1e-3 quasi-static, > 1e-2 not).

    γ̇ is estimated as the head's speed at 2/3 of its radius over a shear band of 10 particle
    diameters, the usual band width in dense granular shear.
    """
    d = 2.0 * spec.radius
    rate = spec.procedure.rotation_rate * (2.0 / 3.0) * spec.geometry.head_radius / (10.0 * d)
    return rate * d / math.sqrt(normal_stress / spec.material.density)


def rotation_rate_for_inertial_number(inertial: float, head_radius: float, normal_stress: float,
                                      density: float) -> float:
    """The head's rotation rate, rad/s, at which a shear step under ``normal_stress`` (Pa) has the
    inertial number ``inertial`` (:func:`inertial_number` solved for ω: ω = 10 I √(σ/ρ) / (⅔ R_h),
    the particle size cancels); ``head_radius`` m, ``density`` the particles' kg/m³."""
    return inertial * 10.0 * math.sqrt(normal_stress / density) / ((2.0 / 3.0) * head_radius)


#: gravitational acceleration, m/s² (every backend's)
GRAVITY = 9.81


def base_shear_capacity(spec: ShearCellSpec, normal_stress: float, bulk_density: float,
                        bed_height: float) -> float:
    """The largest τ (Pa, read as the head's τ = 3T/(2π R_head³)) that a flat base can hold the
    bed against, or NaN where the bound does not apply (base ribs, or a lateral wall with friction:
    then the base is not the only thing that holds the bed).

    With a frictionless lateral wall the base carries the whole of the head's torque T in steady
    shear. A flat base of friction μ_b under a uniform pressure p_b = σ (R_h/R_v)² + ρ g H can resist
    at most μ_b p_b (2π/3) R_v³ (rolling resistance has no moment about the axis), so

        τ_cap = μ_b [σ (R_v/R_h) + ρ g H (R_v/R_h)³].

    When the steady τ reaches τ_cap the bed slides on the base as a block and τ measures the base's
    friction, not the powder's strength.

    Args:
        normal_stress: σ on the head, Pa. bulk_density: ρ of the bed, kg/m³.
        bed_height: H, height of the head's lower face above the base, m.
    """
    g = spec.geometry
    if g.base_ribs > 0 or g.wall_friction > 0:
        return math.nan
    mu_base, _ = spec.effective_base_friction()
    ratio = g.vessel_diameter / 2.0 / g.head_radius
    return mu_base * (normal_stress * ratio + bulk_density * GRAVITY * bed_height * ratio**3)


#: a shear step whose steady τ reaches this fraction of :func:`base_shear_capacity` slid on the base
BASE_SLIP_FRACTION = 0.9


def steady_base_load(spec: ShearCellSpec, steps: "list[StepRecord] | tuple[StepRecord, ...]",
                     bulk_density: "np.ndarray | list[float]") -> float:
    """Mean over the shear steps of steady τ / :func:`base_shear_capacity` (fraction; NaN where the
    bound does not apply). Steady: the second half of each window; ``bulk_density[k]`` (kg/m³) is
    the bed's density before shear step k."""
    loads = []
    for k, step in enumerate(s for s in steps if s.kind == "shear"):
        half = step.shear_stress.size // 2
        if half < 1 or k >= len(bulk_density):
            continue
        cap = base_shear_capacity(spec, float(np.mean(step.normal_stress[half:])), float(bulk_density[k]),
                                  float(np.mean(step.bed_height[half:])))
        loads.append(float(np.mean(step.shear_stress[half:])) / cap)
    return float(np.mean(loads)) if loads else math.nan


#: a shear step whose bottom layer turned, on average over the second half of the window, at this
#: fraction of the head's rotation rate or more slid on its base (see :func:`base_slip`)
BASE_SPIN_SLIP_FRACTION = 0.25


def base_layer_bounds(spec: ShearCellSpec) -> tuple[float, float]:
    """Heights (m) between which a particle's centre lies in the layer whose spin is
    :attr:`StepRecord.base_spin`: one particle diameter just above the base's top (the ribs' tops
    where it has ribs, since particles between the ribs are held by them whatever happens above)."""
    top = spec.geometry.rib_height if spec.geometry.base_ribs > 0 else 0.0
    return top, top + 2.0 * spec.radius


def layer_spin(x: np.ndarray, v: np.ndarray, z_low: float, z_high: float) -> float:
    """Mean angular velocity about the z axis (rad/s) of the particles whose centre height lies in
    [z_low, z_high), from positions ``x`` and velocities ``v`` of shape (n, 3) in m and m/s;
    NaN when the layer is empty. Particles within 1e-9 m of the axis are left out."""
    z = x[:, 2]
    rho2 = x[:, 0] ** 2 + x[:, 1] ** 2
    m = (z >= z_low) & (z < z_high) & (rho2 > 1e-18)
    if not np.any(m):
        return math.nan
    return float(np.mean((x[m, 0] * v[m, 1] - x[m, 1] * v[m, 0]) / rho2[m]))


def base_slip(step: "StepRecord", rotation_rate: float) -> float:
    """How fast the bed's bottom layer turned with the head over the second half of a step: the
    mean of :attr:`StepRecord.base_spin` there over the head's rotation rate (rad/s), a fraction
    (0: the base held the bed and the shear happened in the powder; near 1: the bed turned on its
    base as a block). NaN where the backend did not record the spin."""
    spin = np.asarray(step.base_spin, dtype=float)
    if spin.size < 2 or not np.any(np.isfinite(spin)):
        return math.nan
    return float(np.nanmean(spin[spin.size // 2:]) / rotation_rate)


def locus_warning(normal_stress: np.ndarray, peak_shear_stress: np.ndarray) -> str | None:
    """A warning when one test's yield locus is not physical: the peaks (Pa, shape (k,)) do not rise
    with the normal stress (Pa, shape (k,)), or the fitted AIF is negative; None otherwise. At
    affordable fidelity this is mostly seed noise, which pooling seeds averages out."""
    sigma, tau = np.asarray(normal_stress, float), np.asarray(peak_shear_stress, float)
    if sigma.size < 2 or not (np.all(np.isfinite(sigma)) and np.all(np.isfinite(tau))):
        return None
    order = np.argsort(sigma)
    falls = bool(np.any(np.diff(tau[order]) < 0))
    aif = YieldLocus.fit(sigma, tau).aif_deg
    if not falls and aif >= 0:
        return None
    pairs = ", ".join(f"{t:.0f} Pa at {s / 1e3:g} kPa" for s, t in zip(sigma[order], tau[order]))
    what = "the peaks do not rise with σ" if falls else "the locus falls"
    return (f"{what} ({pairs}; AIF = {aif:.1f}°): one test's locus at this fidelity is mostly seed noise; "
            "pool seeds (seeds_per_point) or use a finer cell (docs/explanation/seed-noise.md)")


def rim_gap_warning(spec: "ShearCellSpec") -> str | None:
    """A warning when a particle can wedge between a blade's outer edge and a frictional vessel
    wall, None otherwise.

    That happens when the gap between the head's rim and the wall (m) lies between one particle
    radius and one diameter (``spec.radius``, m): a particle's centre passes the rim but the particle
    does not fit through. A wall with friction holds the wedge, and τ then measures it, not the
    powder. The presets' gaps lie under one radius (:data:`~calibrax.core.sheartest.presets.RIM_GAP_D`);
    before 2026-12-07 ``converged``'s was 0.02 D, 0.92 d, where a wall of 0.3 read a preshear τ/σ of
    7 to 50 (docs/explanation/sector.md, "A frictional wall and the rim gap").
    """
    g, r = spec.geometry, spec.radius
    gap = g.vessel_diameter / 2.0 - g.head_radius
    if g.wall_friction <= 0.0 or not r < gap < 2.0 * r:
        return None
    return (f"the head's rim is {gap / (2.0 * r):.2f} particle diameters from a frictional wall (geometry.wall_friction = "
            f"{g.wall_friction:g}): a particle can wedge between a blade's edge and the wall, and τ then measures the "
            f"wedge, not the powder; leave a gap of at most half a diameter (geometry.head_radius ≥ "
            f"{math.ceil((g.vessel_diameter / 2.0 - r) * 1e6) / 1e3:.3f} mm; the presets leave 0.24 d) or a frictionless wall "
            "(docs/explanation/sector.md#a-frictional-wall-and-the-rim-gap)")
