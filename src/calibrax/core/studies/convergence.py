"""``calibrax converge``: how coarse may a simulation be before its yield locus changes?

The reference paper's particle-count study (25/34/46/63 particles per cell diameter at fixed R and
H/D), extended to the time-step fraction and the shear rate (inertial number). Each setting runs
with N seeds; the answer is the cheapest setting whose C and AIF, and the robust features (peak
and preshear τ/σ, means over the steps), lie within 2·√(u² + u_finest²) of the finest setting's,
and whose bulk density after preshear lies within
the larger of that and :data:`DENSITY_TOLERANCE` of the finest's. (C and AIF alone are not
enough: with a few seeds their uncertainties are wide, while the density of a coarse cell, shaped
by the wall, can still be 20 % off.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from calibrax.core.config import CampaignConfig
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.core.sheartest.physics import inertial_number
from calibrax.core.studies.study import CaseOutcome, StudyCase
from calibrax.errors import ConfigError, SpecError

#: knob → (cheapest first when sorted ascending?, what "finest" means)
KNOBS = {"particles_per_diameter": True, "dt_fraction": False, "rotation_rate": False, "inertial_number": False}
#: relative bulk-density difference to the finest setting that still counts as converged (about the
#: repeatability of a measured conditioned bulk density; the seed spread of a simulated one can be
#: far smaller)
DENSITY_TOLERANCE = 0.02
#: knob → the ``calibrax converge`` option that sets it
OPTIONS = {"particles_per_diameter": "--particles-per-diameter", "dt_fraction": "--dt-fraction",
           "rotation_rate": "--shear-rate", "inertial_number": "--inertial-number"}


def with_particles_per_diameter(spec: ShearCellSpec, ppd: float) -> ShearCellSpec:
    """The same cell at another particle count: D = ppd·2R, with H/D and the hub radius kept in
    proportion to D (the paper's way: fixed R and H/D), the gap between the head's rim and the wall
    kept in metres (the particles stay, and a gap scaled with D wedges them once it passes one
    radius: docs/explanation/sector.md, "A frictional wall and the rim gap"), and the rotation rate
    scaled by the head radius's inverse, so that the inertial number (∝ ω R_head) is the same in
    every cell and the size axis does not mix in the shear rate."""
    g = spec.geometry
    scale = ppd * 2.0 * spec.radius / g.vessel_diameter
    head_radius = g.vessel_diameter * scale / 2.0 - (g.vessel_diameter / 2.0 - g.head_radius)
    return spec.replace(geometry={"vessel_diameter": g.vessel_diameter * scale, "fill_height": g.fill_height * scale,
                                  "head_radius": head_radius, "hub_radius": g.hub_radius * scale},
                        procedure={"rotation_rate": spec.procedure.rotation_rate * g.head_radius / head_radius})


def vary(spec: ShearCellSpec, knob: str, value: float) -> ShearCellSpec:
    """``spec`` with one fidelity knob set."""
    if knob == "particles_per_diameter":
        return with_particles_per_diameter(spec, value)
    if knob == "dt_fraction":
        return spec.replace(numerics={"dt_fraction": value})
    if knob == "rotation_rate":
        return spec.replace(procedure={"rotation_rate": value})
    if knob == "inertial_number":
        return spec.with_inertial_number(value)
    raise ConfigError("converge", f"unknown knob {knob!r}; allowed: {sorted(KNOBS)}")


def converge_cases(config: CampaignConfig, backend: str, seeds: int,
                   settings: dict[str, list[float]]) -> list[StudyCase]:
    """One case per (knob, value); the other knobs keep the config's values."""
    cases = []
    for knob, values in settings.items():
        option = OPTIONS.get(knob, knob)
        if len(values) < 2:
            raise ConfigError(option, f"give at least two comma-separated values to compare, got {values}")
        if len(set(values)) != len(values):
            raise ConfigError(option, f"each value once, got {values}")
        for v in values:
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(option, f"values must be finite and > 0, got {v:g}")
            if knob in ("dt_fraction", "inertial_number") and v > 1:
                raise ConfigError(option, f"{'a fraction of the critical time step' if knob == 'dt_fraction' else 'an inertial number'} lies in (0, 1], got {v:g}")
            try:
                spec = vary(config.spec, knob, v).validate()
            except SpecError as exc:
                raise ConfigError(option, f"{v:g} gives an invalid cell: {exc}") from None
            cases.append(StudyCase(f"{knob}={v:g}", backend, spec,
                                   tuple(config.seed * 1000 + s for s in range(seeds)), {knob: float(v)}))
    return cases


@dataclass(frozen=True)
class Verdict:
    """The cheapest setting of one knob whose locus lies within the uncertainty of the finest."""

    knob: str
    finest: float
    cheapest_ok: float | None
    rows: list[tuple[float, dict[str, float], bool]]  # (value, summary, within)

    def sentence(self) -> str:
        """The verdict: always names the cheapest setting (the finest itself when no other is within)."""
        if self.cheapest_ok is None:
            return (f"{self.knob}: the cheapest setting is the finest, {self.finest:g}: no coarser setting's C, AIF "
                    "bulk density and peak and preshear τ/σ lie within the finest's uncertainty; go finer to "
                    "see convergence")
        return (f"{self.knob}: the cheapest setting is {self.cheapest_ok:g}: its C, AIF, bulk density and peak and "
                f"preshear τ/σ lie within the uncertainty of the finest's ({self.finest:g})")


#: the robust features a converged setting must also reproduce (calibrax.core.data.features, means over steps)
ROBUST = ("peak_ratio", "preshear_ratio")


def within_finest(s: dict[str, float], fs: dict[str, float]) -> bool:
    """Whether a setting's summary ``s`` (see :meth:`CaseOutcome.summary`) lies within the finest's
    ``fs``: C and AIF within 2·√(u² + u_f²); the robust features (peak and preshear τ/σ, where
    the summaries have them) within 2·√(u² + u_f²) with u = seed s.d./√seeds; bulk density within
    max(2·√(u² + u_f²), DENSITY_TOLERANCE·ρ_f) (a u that one seed leaves undefined counts as 0)."""
    for q in ("cohesion", "aif"):
        if not (q in s and q in fs and abs(s[q] - fs[q]) <= 2 * math.hypot(s[f"{q}_u"], fs[f"{q}_u"])):
            return False
    for q in ROBUST:
        if q in s and q in fs:
            u = [x.get(f"{q}_sd", math.nan) / math.sqrt(max(x.get("seeds_ok", 1.0), 1.0)) for x in (s, fs)]
            if not abs(s[q] - fs[q]) <= 2 * math.hypot(*(0.0 if math.isnan(v) else v for v in u)):
                return False
    if "bulk_density" not in s or "bulk_density" not in fs:
        return False
    u = math.hypot(*(0.0 if math.isnan(x) else x for x in (s["bulk_density_u"], fs["bulk_density_u"])))
    return abs(s["bulk_density"] - fs["bulk_density"]) <= max(2 * u, DENSITY_TOLERANCE * fs["bulk_density"])


def verdicts(outcomes: list[CaseOutcome]) -> list[Verdict]:
    """One verdict per knob studied."""
    out = []
    knobs: dict[str, list[tuple[float, CaseOutcome]]] = {}
    for o in outcomes:
        (knob, value), = o.case.coords.items()
        knobs.setdefault(knob, []).append((value, o))
    for knob, items in knobs.items():
        fine_high = KNOBS[knob]  # more particles is finer; a smaller dt or slower shear is finer
        items.sort(key=lambda t: t[0], reverse=not fine_high)  # cheapest first
        finest_value, finest = items[-1]
        fs = finest.summary()
        rows, cheapest = [], None
        for value, o in items:
            s = o.summary()
            within = within_finest(s, fs)
            rows.append((value, s, within))
            if within and cheapest is None and value != finest_value:
                cheapest = value
        out.append(Verdict(knob, finest_value, cheapest, rows))
    return out


def inertial_numbers(spec: ShearCellSpec) -> list[float]:
    """I of each shear step of a spec."""
    return [inertial_number(spec, s) for s in spec.procedure.shear_stresses]
