"""The spec's validation: every field checked, and an error that names the field and what is allowed."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from calibrax.core.sheartest.fields import declared_fields, get_path
from calibrax.errors import SpecError

if TYPE_CHECKING:
    from calibrax.core.sheartest.spec import ShearCellSpec

def validate_spec(spec: "ShearCellSpec", min_particles: int = 50) -> "ShearCellSpec":
    """Raise :class:`SpecError` naming the field and what is allowed; return ``spec`` if valid.

    Every declared field's type and range comes from its declaration
    (:mod:`calibrax.core.sheartest.fields`); what is checked here besides are the rules between
    fields."""
    m, g, p = spec.material, spec.geometry, spec.procedure

    def finite(key: str, value: float) -> None:
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            raise SpecError(key, f"must be a finite number, got {value!r}")

    def positive(key: str, value: float) -> None:
        finite(key, value)
        if value <= 0:
            raise SpecError(key, f"must be > 0, got {value!r}")

    for path, info in declared_fields(type(spec)):
        info.check(path, get_path(spec, path))
    if m.bond_number > 0 and m.cohesion_energy_density > 0:
        raise SpecError("material.bond_number", "set cohesion either as a Bond number or as "
                        "material.cohesion_energy_density (J/m³), not both")
    if g.head_radius >= g.vessel_diameter / 2:
        raise SpecError("geometry.head_radius", "must be smaller than the vessel radius")
    if g.hub_radius >= g.head_radius:
        raise SpecError("geometry.hub_radius", "must be smaller than the head radius")
    base_mu, _ = spec.effective_base_friction()
    if g.wall_friction == 0 and base_mu == 0 and g.base_ribs == 0:
        raise SpecError("geometry.base_friction",
                        "wall, base and ribs are all frictionless: nothing holds the bed and it turns "
                        "with the head; give the base friction (default: the particles' μs) or ribs")
    _validate_sector(spec)
    if g.blade_height >= g.fill_height:
        raise SpecError("geometry.blade_height", "must be smaller than the fill height")
    if spec.numerics.device not in ("cpu", "cuda"):
        raise SpecError("numerics.device", f"must be cpu or cuda, got {spec.numerics.device!r}")
    sd = spec.size_distribution
    if sd.kind not in ("mono", "lognormal", "table"):
        raise SpecError("size_distribution.kind", f"must be mono, lognormal or table, got {sd.kind!r}")
    if sd.kind == "lognormal":
        if sd.sigma_log == 0:
            raise SpecError("size_distribution.sigma_log", "must be > 0 for a lognormal distribution (mono has "
                            f"none), got {sd.sigma_log}")
    if sd.kind == "table":
        if len(sd.radii) == 0 or len(sd.radii) != len(sd.fractions):
            raise SpecError("size_distribution.radii", "table needs radii and fractions of the same length")
        for r in sd.radii:
            positive("size_distribution.radii", r)
        for f_ in sd.fractions:
            finite("size_distribution.fractions", f_)
            if f_ < 0:
                raise SpecError("size_distribution.fractions", "must be ≥ 0")
        if not math.isclose(sum(sd.fractions), 1.0, rel_tol=1e-6):
            raise SpecError("size_distribution.fractions", f"must sum to 1, got {sum(sd.fractions)}")
    if len(p.shear_stresses) < 2:
        raise SpecError("procedure.shear_stresses", "needs at least two shear stresses for a yield locus")
    for s in p.shear_stresses:
        positive("procedure.shear_stresses", s)
        if s >= p.preshear_stress:
            raise SpecError("procedure.shear_stresses",
                            f"each must be below the preshear stress {p.preshear_stress} Pa, got {s}")
    if len(set(p.shear_stresses)) < 2:
        raise SpecError("procedure.shear_stresses", "needs at least two distinct values")
    if p.preshear_max_rotation is not None:
        if p.preshear_max_rotation < p.preshear_rotation:
            raise SpecError("procedure.preshear_max_rotation",
                            f"the cap ({p.preshear_max_rotation} rad) must be at least the shortest preshear, "
                            f"procedure.preshear_rotation ({p.preshear_rotation} rad)")
        if p.preshear_max_rotation < 2.0 * p.steady_window:
            raise SpecError("procedure.steady_window",
                            f"the steady-state criterion compares two windows of {p.steady_window} rad, more than "
                            f"the cap procedure.preshear_max_rotation ({p.preshear_max_rotation} rad) allows; "
                            "allowed: steady_window ≤ preshear_max_rotation / 2")
    _validate_compressibility(p.compressibility_stresses, p.preshear_stress)
    if not isinstance(p.branches, bool):
        raise SpecError("procedure.branches", f"must be true or false, got {p.branches!r}")
    if p.peak_window >= p.shear_rotation:
        raise SpecError("procedure.peak_window", "must be smaller than the shear rotation")
    if spec.particle_count < min_particles:
        raise SpecError("geometry.vessel_diameter",
                        f"the cell holds only {spec.particle_count} particles (< {min_particles}); "
                        "enlarge the cell or shrink the particles")
    gap = 2.0 * math.pi * g.head_radius / g.blade_count
    if gap < 2.0 * spec.radius:
        raise SpecError("geometry.blade_count",
                        f"blades are {gap * 1e3:.2f} mm apart at the rim, less than a particle diameter "
                        f"({2e3 * spec.radius:.2f} mm): too few particles for the head")
    return spec


def _validate_sector(spec: "ShearCellSpec") -> None:
    """A sector 1/k of the cell: k divides the blade and rib counts (the sector holds whole
    blades and ribs), and its core stays inside the hub (where the blades and ribs start)."""
    g, key = spec.geometry, "geometry.sector"
    k = g.sector
    if g.core_radius is not None:
        if g.core_radius < spec.sector_core_radius:
            raise SpecError("geometry.core_radius", f"a 1/{k} sector needs a core of at least "
                            f"{spec.sector_core_radius * 1e3:.3f} mm, or a particle meets its own image; got "
                            f"{g.core_radius * 1e3:.3f} mm (null: the sector's own)")
        if g.core_radius >= g.hub_radius:
            raise SpecError("geometry.core_radius", f"must be smaller than the hub (geometry.hub_radius = "
                            f"{g.hub_radius * 1e3:.2f} mm), where the blades start; got {g.core_radius * 1e3:.2f} mm")
    if k == 1:
        return
    counts = {"geometry.blade_count": g.blade_count, **({"geometry.base_ribs": g.base_ribs} if g.base_ribs else {})}
    for name, count in counts.items():
        if count % k:
            divisors = [d for d in range(1, count + 1) if all(c % d == 0 for c in counts.values())]
            raise SpecError(key, f"must divide {name} ({count}) so that the sector holds whole blades and ribs, "
                            f"got {k}; allowed: {divisors}")
    if spec.sector_core_radius >= g.hub_radius:
        allowed = [d for d in range(1, g.blade_count + 1)
                   if g.blade_count % d == 0 and (g.base_ribs % d == 0 if g.base_ribs else True)
                   and spec.replace(geometry={"sector": d}).sector_core_radius < g.hub_radius]
        raise SpecError(key, f"a 1/{k} sector needs a frictionless core of radius {spec.sector_core_radius * 1e3:.2f} mm "
                        f"round the axis, wider than the hub (geometry.hub_radius = {g.hub_radius * 1e3:.2f} mm) "
                        f"where the blades start; allowed: {allowed}")


def _validate_compressibility(stresses: tuple[float, ...], preshear_stress: float) -> None:
    """The compressibility ramp: finite stresses > 0, Pa, strictly increasing, none above the
    preshear stress, at least two (one stress compresses nothing to compare with)."""
    key = "procedure.compressibility_stresses"
    if not isinstance(stresses, (tuple, list)):
        raise SpecError(key, f"must be a list of normal stresses in Pa, got {stresses!r}")
    if len(stresses) == 0:
        return
    if len(stresses) < 2:
        raise SpecError(key, "needs at least two stresses (the first is the reference the compressibility is "
                        "measured from), or none; e.g. [1000, 2000, 4000, 6000, 8000, 10000, 12000, 15000]")
    for s in stresses:
        if not isinstance(s, (int, float)) or isinstance(s, bool) or not math.isfinite(s) or s <= 0:
            raise SpecError(key, f"each must be a finite number > 0 (Pa), got {s!r}")
    steps = [b - a for a, b in zip(stresses, stresses[1:])]
    if min(steps) <= 0:
        k = steps.index(min(steps))
        raise SpecError(key, f"must increase strictly, as the FT4's ramp does: {stresses[k]} Pa is followed by "
                        f"{stresses[k + 1]} Pa")
    if stresses[-1] > preshear_stress:
        raise SpecError(key, f"the last stress ({stresses[-1]} Pa) must not exceed the preshear stress "
                        f"procedure.preshear_stress ({preshear_stress} Pa): the bed is consolidated at that after")
