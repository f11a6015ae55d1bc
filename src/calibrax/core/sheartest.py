"""The FT4 cylindrical shear test as one backend-neutral spec, and its result.

``ShearCellSpec`` describes geometry, particles, material, procedure and numerics in SI units
(Pa, m, s, rad, kg). Every backend (numba_dem, LIGGGHTS, YADE) simulates the *same* spec and
returns a ``ShearTestResult`` whose peaks are found by the *same* function here, so that
backends can be compared like with like.

Defaults are the reference paper's Table 1 material (E = 25 GPa, μs = 0.5, ν = 0.25, e = 0.3,
μr = 0.5, ρ = 3000 kg/m³, R = 0.9 mm) and its procedure (preshear 15 kPa; shear at 9, 8, 7, 6 kPa).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from calibrax.core.yieldlocus import MohrAnalysis, YieldLocus
from calibrax.errors import SimulationFailed, SpecError

__all__ = [
    "Material", "SizeDistribution", "Geometry", "Procedure", "Numerics", "ShearCellSpec",
    "StepRecord", "Provenance", "ShearTestResult", "YieldLocus", "MohrAnalysis",
    "critical_time_step", "find_peak", "shear_stress_from_torque", "inertial_number",
    "base_shear_capacity", "steady_base_load", "BASE_SLIP_FRACTION", "BASE_SPIN_SLIP_FRACTION",
    "base_slip", "base_layer_bounds", "layer_spin", "GRAVITY", "PROCEDURES", "FIDELITY_PRESETS",
    "preshear_drift", "preshear_steady_part", "steady_window_samples", "running_mean_width", "stress_at_peak", "steady_schedule", "INSERTION_STRESS_FRACTION", "INSERTION_FRICTION", "INSERTION_TIME_FACTOR", "INSERTION_TOLERANCE_RADII",
    "CONSOLIDATION_LIMIT_ROTATION",
    "insertion_time_limit",
]


# ----------------------------------------------------------------------------- value objects
@dataclass(frozen=True)
class Material:
    """Particle material, Table 1 of the reference paper by default.

    Attributes:
        youngs_modulus: E, Pa.
        poisson_ratio: ν, in [0, 0.5).
        restitution: e, in (0, 1]; the damping of LIGGGHTS' ``hertz`` model is derived from it.
        sliding_friction: μs, ≥ 0.
        rolling_friction: μr, ≥ 0 (EPSD2 type, no viscous part).
        density: ρ, kg/m³.
        cohesion_energy_density: k of the simplified JKR model (LIGGGHTS ``cohesion sjkr``,
            F = k·A with A the contact area), J/m³; 0 = no cohesion (the default).
    """

    youngs_modulus: float = 25.0e9
    poisson_ratio: float = 0.25
    restitution: float = 0.3
    sliding_friction: float = 0.5
    rolling_friction: float = 0.5
    density: float = 3000.0
    cohesion_energy_density: float = 0.0

    @property
    def reduced_modulus(self) -> float:
        """Ẽ = E / (1 − ν²), Pa."""
        return self.youngs_modulus / (1.0 - self.poisson_ratio**2)


@dataclass(frozen=True)
class SizeDistribution:
    """Particle radii. ``mono`` (default), ``lognormal`` or ``table``.

    Attributes:
        kind: "mono" | "lognormal" | "table".
        sigma_log: standard deviation of ln(r) for ``lognormal`` (radius ``Particles.radius`` is the
            median), truncated to [r·min_ratio, r·max_ratio].
        radii: table radii, m (``table`` only).
        fractions: table number fractions (``table`` only), summing to 1.
    """

    kind: Literal["mono", "lognormal", "table"] = "mono"
    sigma_log: float = 0.0
    min_ratio: float = 0.5
    max_ratio: float = 2.0
    radii: tuple[float, ...] = ()
    fractions: tuple[float, ...] = ()

    def sample(self, median_radius: float, n: int, rng: np.random.Generator) -> np.ndarray:
        """Draw ``n`` radii (m), shape (n,)."""
        if self.kind == "mono":
            return np.full(n, median_radius)
        if self.kind == "lognormal":
            r = median_radius * np.exp(rng.normal(0.0, self.sigma_log, n))
            return np.clip(r, median_radius * self.min_ratio, median_radius * self.max_ratio)
        idx = rng.choice(len(self.radii), size=n, p=np.asarray(self.fractions) / np.sum(self.fractions))
        return np.asarray(self.radii, dtype=float)[idx]

    def mean_volume_factor(self, median_radius: float) -> float:
        """E[r³] / R³, used to turn a fill volume into a particle count."""
        if self.kind == "mono":
            return 1.0
        if self.kind == "lognormal":
            return float(math.exp(4.5 * self.sigma_log**2))
        r = np.asarray(self.radii) / median_radius
        f = np.asarray(self.fractions) / np.sum(self.fractions)
        return float(np.sum(f * r**3))


@dataclass(frozen=True)
class Geometry:
    """The FT4 cylindrical shear cell, scaled to the particles (all m).

    The head is a disc of radius ``head_radius`` with ``blade_count`` radial blades of height
    ``blade_height`` hanging below it, from ``hub_radius`` out to ``head_radius``. The lateral wall
    is frictionless by default (the paper's hypothesis). The base holds the bed with ``base_ribs``
    radial ribs (vertical plates from the axis to the wall, ``rib_height`` high, one particle
    diameter by default), as ring shear cells hold theirs with cleats: a flat base of the particles'
    own friction can hold at most τ ≈ 0.55 σ, below the powder's strength, so the bed would slide
    on it as a block and τ would measure the base (``base_ribs: 0`` gives that flat base). The base
    and ribs take the particles' μs and μr (``None``). The lateral wall's rolling friction
    ``wall_rolling_friction`` defaults (``None``) to the particles' μr when the wall has sliding
    friction and to 0 when it has none (:meth:`ShearCellSpec.effective_wall_rolling_friction`).
    """

    vessel_diameter: float = 61.2e-3
    fill_height: float = 53.9e-3
    head_radius: float = 29.4e-3
    blade_count: int = 18
    blade_height: float = 3.6e-3
    hub_radius: float = 3.0e-3
    wall_friction: float = 0.0
    wall_rolling_friction: float | None = None
    base_friction: float | None = None
    base_rolling_friction: float | None = None
    head_friction: float | None = None
    base_ribs: int = 18
    rib_height: float = 1.8e-3


#: consolidation may last this many times its minimum (one preshear rotation) before the backends
#: give up waiting for the head to settle; consolidations measured at tiny and quick settled within
#: 1.1–1.8 × the minimum (0.033–0.036 s of 0.02–0.03 s)
CONSOLIDATION_LIMIT_FACTOR = 6.0
#: ... and at least this rotation's time: with the blades in the bed (INSERTION_STRESS_FRACTION),
#: consolidations at tiny took 0.06–0.14 s (0.4–0.9 rad at 6 rad/s, 20 seeds), longer than six
#: times a short preshear's minimum (the smoke test's 0.02 rad: 0.06 s)
CONSOLIDATION_LIMIT_ROTATION = 1.0


#: the blades go into the bed under this fraction of the preshear stress, before the bed is
#: consolidated. Placed above the bed and brought down by the servo at the preshear stress, the
#: blades never entered it: zero-thickness blade edges on a jammed bed carried the whole 15 kPa,
#: the space between the blades stayed empty (solid fraction < 0.03 within 1.5 diameters of the
#: disc, tiny, numba_dem) and τ measured the edges sliding on the bed's top (τ/σ of 0.16 to 0.73
#: from one 0.15 rad window to the next in one preshear), the largest part of the seed scatter
#: (benchmarks/shear_diagnostics.py)
INSERTION_STRESS_FRACTION = 0.1
#: particle–particle and particle–head friction while the blades go in (the pour's, numba_dem's
#: POUR_FRICTION); the material's friction is switched on before consolidation. At the material's
#: friction the edges did not cut in even at 1.5 kPa.
INSERTION_FRICTION = 0.1
#: the insertion ends when the head's lower face has come down to within INSERTION_TOLERANCE_RADII
#: particle radii of the top of the poured bed's highest particle (every backend measures that the
#: same way; one seed in twenty stopped 0.07 radii short at the time limit), or after this many times the time
#: the head takes to come down by its blades' height and two particle diameters at the approach
#: speed (then the result warns; :func:`insertion_time_limit`)
INSERTION_TIME_FACTOR = 3.0
INSERTION_TOLERANCE_RADII = 0.1


def insertion_time_limit(spec: "ShearCellSpec", approach_speed: float) -> float:
    """The longest blade insertion, s: :data:`INSERTION_TIME_FACTOR` × (blade height + 2
    particle diameters) / ``approach_speed`` (m/s, the backend's servo speed limit while the head
    comes down), and at least the consolidation's minimum time."""
    travel = spec.geometry.blade_height + 4.0 * spec.radius
    return max(INSERTION_TIME_FACTOR * travel / approach_speed, spec.procedure.consolidation_min_time)


@dataclass(frozen=True)
class Procedure:
    """The test sequence: for each shear stress, preshear then shear (Pa, rad, rad/s, s).

    Attributes:
        preshear_stress: σ of every preshear, Pa (15 kPa in the paper).
        shear_stresses: σ of each shear step, Pa, in the order run (9, 8, 7, 6 kPa in the paper).
        rotation_rate: head rotation rate during preshear and shear, rad/s.
        preshear_rotation: the shortest rotation of each preshear, rad.
        preshear_max_rotation: the longest rotation of each preshear, rad, or None (each preshear
            turns exactly ``preshear_rotation``). When set, a preshear turns on past its minimum
            until τ/σ is steady, as the FT4's does: the means of τ/σ over the last two windows
            of ``steady_window`` rad differ by at most ``steady_tolerance`` of the last
            (:func:`preshear_drift`); at the cap the result warns that it was not steady.
        steady_window: width of each of the two windows the steady-state criterion compares, rad.
        steady_tolerance: the largest relative difference of their mean τ/σ, > 0.
        shear_rotation: head rotation of each shear step (past the peak), rad.
        settle_time: time the head holds the new σ, not rotating, before each rotation starts, s.
        peak_window: width of the running mean the peak is taken from, rad of rotation.
    """

    preshear_stress: float = 15.0e3
    shear_stresses: tuple[float, ...] = (9.0e3, 8.0e3, 7.0e3, 6.0e3)
    rotation_rate: float = 1.0
    preshear_rotation: float = 0.30
    preshear_max_rotation: float | None = None
    steady_window: float = 0.1
    steady_tolerance: float = 0.05
    shear_rotation: float = 0.20
    settle_time: float = 0.02
    peak_window: float = 0.01

    @property
    def consolidation_min_time(self) -> float:
        """Shortest consolidation, s: one preshear rotation of turning (at least 10 ms), so that the
        blades work their way in and the bed compacts before the first preshear is recorded."""
        return max(0.01, self.preshear_rotation / self.rotation_rate)

    @property
    def consolidation_time_limit(self) -> float:
        """Longest consolidation, s: :data:`CONSOLIDATION_LIMIT_FACTOR` × the shortest. Past it the
        backends stop waiting for the head to settle and warn. Derived from the procedure, so that a
        slow rotation (the paper's 0.5 rad/s: 0.6 s minimum, 3.6 s limit) is not cut off before its
        first rotation ends, and at least :data:`CONSOLIDATION_LIMIT_ROTATION` rad of turning;
        ``tiny`` gets 0.30 s, ``quick`` 0.36 s."""
        return max(CONSOLIDATION_LIMIT_FACTOR * self.consolidation_min_time,
                   CONSOLIDATION_LIMIT_ROTATION / self.rotation_rate)


@dataclass(frozen=True)
class Numerics:
    """Time step, output and randomness.

    Attributes:
        dt_fraction: Δt as a fraction of the paper's critical step (eq. 1), in (0, 1].
        stress_for_dt: σ0 in eq. (1), Pa; defaults to the preshear stress.
        sample_interval: time between recorded samples of the time series, s.
        seed: random seed of the packing; same seed and thread count → identical result.
        threads: threads (or MPI ranks) the backend may use.
    """

    dt_fraction: float = 0.05
    stress_for_dt: float | None = None
    sample_interval: float = 2.0e-4
    seed: int = 0
    threads: int = 1


@dataclass(frozen=True)
class ShearCellSpec:
    """One FT4 shear test, complete and backend-neutral. Use :meth:`preset` to build one."""

    geometry: Geometry = field(default_factory=Geometry)
    material: Material = field(default_factory=Material)
    radius: float = 0.9e-3
    size_distribution: SizeDistribution = field(default_factory=SizeDistribution)
    fill_solid_fraction: float = 0.60
    procedure: Procedure = field(default_factory=Procedure)
    numerics: Numerics = field(default_factory=Numerics)
    name: str = "custom"

    # -- derived quantities ------------------------------------------------------------------
    @property
    def particles_per_diameter(self) -> float:
        """Cell diameter in particle diameters, D / (2R)."""
        return self.geometry.vessel_diameter / (2.0 * self.radius)

    @property
    def particle_count(self) -> int:
        """Particles needed to fill the cell to ``fill_height`` at ``fill_solid_fraction``."""
        g = self.geometry
        v_cell = math.pi * (g.vessel_diameter / 2) ** 2 * g.fill_height
        v_p = 4.0 / 3.0 * math.pi * self.radius**3 * self.size_distribution.mean_volume_factor(self.radius)
        return int(round(self.fill_solid_fraction * v_cell / v_p))

    @property
    def critical_time_step(self) -> float:
        """Δt_crit of the paper's eq. (1) at σ0 (``numerics.stress_for_dt`` or the preshear σ), s."""
        s0 = self.numerics.stress_for_dt or self.procedure.preshear_stress
        r_min = self.radius * (self.size_distribution.min_ratio if self.size_distribution.kind == "lognormal" else 1.0)
        if self.size_distribution.kind == "table":
            r_min = min(self.size_distribution.radii)
        return critical_time_step(r_min, self.material.density, self.material.reduced_modulus, s0)

    @property
    def time_step(self) -> float:
        """Δt = dt_fraction · Δt_crit, s."""
        return self.numerics.dt_fraction * self.critical_time_step

    def effective_base_friction(self) -> tuple[float, float]:
        """(μs, μr) of the base: the material's unless set."""
        g, m = self.geometry, self.material
        return (m.sliding_friction if g.base_friction is None else g.base_friction,
                m.rolling_friction if g.base_rolling_friction is None else g.base_rolling_friction)

    def effective_wall_rolling_friction(self) -> float:
        """μr of the lateral wall: ``geometry.wall_rolling_friction`` if set, else the particles' μr
        when the wall has sliding friction and 0 when it has none (every backend's former rule)."""
        g = self.geometry
        if g.wall_rolling_friction is not None:
            return g.wall_rolling_friction
        return self.material.rolling_friction if g.wall_friction > 0 else 0.0

    def effective_head_friction(self) -> float:
        """μs of the head's blades and face: the material's unless set."""
        g = self.geometry
        return self.material.sliding_friction if g.head_friction is None else g.head_friction

    # -- construction ------------------------------------------------------------------------
    @classmethod
    def preset(cls, fidelity: str = "quick", procedure: str = "paper", **overrides: Any) -> "ShearCellSpec":
        """Build a spec from a fidelity preset and a procedure preset.

        Args:
            fidelity: a key of :data:`FIDELITY_PRESETS` ("paper", "quick", "tiny").
            procedure: a key of :data:`PROCEDURES` ("paper", "astm_d7891").
            overrides: ``material=Material(...)``, ``radius=...``, ``numerics={...}`` etc.; dicts
                update the preset's sub-dataclass field by field.
        """
        if fidelity not in FIDELITY_PRESETS:
            raise SpecError("cell.preset", f"unknown fidelity preset {fidelity!r}; allowed: {sorted(FIDELITY_PRESETS)}")
        if procedure not in PROCEDURES:
            raise SpecError("cell.procedure.preset", f"unknown procedure {procedure!r}; allowed: {sorted(PROCEDURES)}")
        p = FIDELITY_PRESETS[fidelity]
        radius = float(overrides.pop("radius", 0.9e-3))
        d = 2.0 * radius
        diameter = p["particles_per_diameter"] * d
        geometry = Geometry(
            vessel_diameter=diameter,
            fill_height=p["height_ratio"] * diameter,
            head_radius=0.48 * diameter,
            blade_count=p["blade_count"],
            blade_height=p["blade_height_d"] * d,
            hub_radius=0.1 * diameter,
            base_ribs=p["base_ribs"],
            rib_height=d,
        )
        proc = dataclasses.replace(PROCEDURES[procedure], **p["procedure"])
        numerics = Numerics(**p["numerics"])
        spec = cls(geometry=geometry, radius=radius, procedure=proc, numerics=numerics, name=fidelity)
        return spec.replace(**overrides)

    def replace(self, **changes: Any) -> "ShearCellSpec":
        """A copy with fields changed; a dict value updates a sub-dataclass field by field."""
        resolved: dict[str, Any] = {}
        for key, value in changes.items():
            if key not in {f.name for f in dataclasses.fields(self)}:
                raise SpecError(f"cell.{key}", f"unknown field; allowed: {[f.name for f in dataclasses.fields(self)]}")
            current = getattr(self, key)
            if isinstance(value, dict) and dataclasses.is_dataclass(current):
                allowed = {f.name for f in dataclasses.fields(current)}
                unknown = set(value) - allowed
                if unknown:
                    raise SpecError(f"cell.{key}.{sorted(unknown)[0]}", f"unknown field; allowed: {sorted(allowed)}")
                value = dataclasses.replace(current, **value)
            resolved[key] = value
        return dataclasses.replace(self, **resolved)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (tuples become lists)."""
        return json.loads(json.dumps(dataclasses.asdict(self)))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "ShearCellSpec":
        """Inverse of :meth:`to_dict`."""
        d = dict(data)
        sub = {"geometry": Geometry, "material": Material, "size_distribution": SizeDistribution,
               "procedure": Procedure, "numerics": Numerics}
        for key, typ in sub.items():
            if key in d:
                fields_ = dict(d[key])
                for f in dataclasses.fields(typ):
                    if f.name in fields_ and isinstance(fields_[f.name], list):
                        fields_[f.name] = tuple(fields_[f.name])
                d[key] = typ(**fields_)
        return cls(**d)

    def spec_hash(self) -> str:
        """A short stable hash of the whole spec (seed included)."""
        blob = json.dumps(self.to_dict(), sort_keys=True).encode()
        return hashlib.sha256(blob).hexdigest()[:16]

    def validate(self, min_particles: int = 50) -> "ShearCellSpec":
        """Raise :class:`SpecError` naming the field and what is allowed; return self if valid."""
        m, g, p, n = self.material, self.geometry, self.procedure, self.numerics

        def finite(key: str, value: float) -> None:
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise SpecError(key, f"must be a finite number, got {value!r}")

        def positive(key: str, value: float) -> None:
            finite(key, value)
            if value <= 0:
                raise SpecError(key, f"must be > 0, got {value!r}")

        positive("radius", self.radius)
        positive("material.youngs_modulus", m.youngs_modulus)
        positive("material.density", m.density)
        finite("material.poisson_ratio", m.poisson_ratio)
        if not 0.0 <= m.poisson_ratio < 0.5:
            raise SpecError("material.poisson_ratio", f"must lie in [0, 0.5), got {m.poisson_ratio}")
        finite("material.restitution", m.restitution)
        if not 0.0 < m.restitution <= 1.0:
            raise SpecError("material.restitution", f"must lie in (0, 1], got {m.restitution}")
        for key in ("sliding_friction", "rolling_friction", "cohesion_energy_density"):
            finite(f"material.{key}", getattr(m, key))
            if getattr(m, key) < 0:
                raise SpecError(f"material.{key}", f"must be ≥ 0, got {getattr(m, key)}")
        for key in ("vessel_diameter", "fill_height", "head_radius", "blade_height", "hub_radius", "rib_height"):
            positive(f"geometry.{key}", getattr(g, key))
        if g.head_radius >= g.vessel_diameter / 2:
            raise SpecError("geometry.head_radius", "must be smaller than the vessel radius")
        if g.hub_radius >= g.head_radius:
            raise SpecError("geometry.hub_radius", "must be smaller than the head radius")
        if not isinstance(g.blade_count, int) or g.blade_count < 1:
            raise SpecError("geometry.blade_count", f"must be an integer ≥ 1, got {g.blade_count!r}")
        if not isinstance(g.base_ribs, int) or g.base_ribs < 0:
            raise SpecError("geometry.base_ribs", f"must be an integer ≥ 0, got {g.base_ribs!r}")
        for key in ("wall_friction", "wall_rolling_friction", "base_friction", "base_rolling_friction",
                    "head_friction"):
            value = getattr(g, key)
            if value is not None:
                finite(f"geometry.{key}", value)
                if value < 0:
                    raise SpecError(f"geometry.{key}", f"must be ≥ 0, got {value}")
        base_mu, _ = self.effective_base_friction()
        if g.wall_friction == 0 and base_mu == 0 and g.base_ribs == 0:
            raise SpecError("geometry.base_friction",
                            "wall, base and ribs are all frictionless: nothing holds the bed and it turns "
                            "with the head; give the base friction (default: the particles' μs) or ribs")
        if g.blade_height >= g.fill_height:
            raise SpecError("geometry.blade_height", "must be smaller than the fill height")
        sd = self.size_distribution
        if sd.kind not in ("mono", "lognormal", "table"):
            raise SpecError("size_distribution.kind", f"must be mono, lognormal or table, got {sd.kind!r}")
        if sd.kind == "lognormal":
            finite("size_distribution.sigma_log", sd.sigma_log)
            if not 0 < sd.sigma_log <= 1.0:
                raise SpecError("size_distribution.sigma_log", f"must lie in (0, 1], got {sd.sigma_log}")
            if not 0 < sd.min_ratio <= 1.0 <= sd.max_ratio:
                raise SpecError("size_distribution.min_ratio", "need 0 < min_ratio ≤ 1 ≤ max_ratio")
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
        finite("fill_solid_fraction", self.fill_solid_fraction)
        if not 0.3 <= self.fill_solid_fraction <= 0.74:
            raise SpecError("fill_solid_fraction", f"must lie in [0.3, 0.74], got {self.fill_solid_fraction}")
        positive("procedure.preshear_stress", p.preshear_stress)
        if len(p.shear_stresses) < 2:
            raise SpecError("procedure.shear_stresses", "needs at least two shear stresses for a yield locus")
        for s in p.shear_stresses:
            positive("procedure.shear_stresses", s)
            if s >= p.preshear_stress:
                raise SpecError("procedure.shear_stresses",
                                f"each must be below the preshear stress {p.preshear_stress} Pa, got {s}")
        if len(set(p.shear_stresses)) < 2:
            raise SpecError("procedure.shear_stresses", "needs at least two distinct values")
        for key in ("rotation_rate", "preshear_rotation", "shear_rotation", "peak_window"):
            positive(f"procedure.{key}", getattr(p, key))
        finite("procedure.settle_time", p.settle_time)
        if p.settle_time < 0:
            raise SpecError("procedure.settle_time", "must be ≥ 0")
        positive("procedure.steady_window", p.steady_window)
        positive("procedure.steady_tolerance", p.steady_tolerance)
        if p.preshear_max_rotation is not None:
            positive("procedure.preshear_max_rotation", p.preshear_max_rotation)
            if p.preshear_max_rotation < p.preshear_rotation:
                raise SpecError("procedure.preshear_max_rotation",
                                f"the cap ({p.preshear_max_rotation} rad) must be at least the shortest preshear, "
                                f"procedure.preshear_rotation ({p.preshear_rotation} rad)")
            if p.preshear_max_rotation < 2.0 * p.steady_window:
                raise SpecError("procedure.steady_window",
                                f"the steady-state criterion compares two windows of {p.steady_window} rad, more than "
                                f"the cap procedure.preshear_max_rotation ({p.preshear_max_rotation} rad) allows; "
                                "allowed: steady_window ≤ preshear_max_rotation / 2")
        if p.peak_window >= p.shear_rotation:
            raise SpecError("procedure.peak_window", "must be smaller than the shear rotation")
        positive("numerics.dt_fraction", n.dt_fraction)
        if n.dt_fraction > 1.0:
            raise SpecError("numerics.dt_fraction", f"must lie in (0, 1] (a fraction of Δt_crit), got {n.dt_fraction}")
        if n.stress_for_dt is not None:
            positive("numerics.stress_for_dt", n.stress_for_dt)
        positive("numerics.sample_interval", n.sample_interval)
        if not isinstance(n.seed, int) or isinstance(n.seed, bool) or n.seed < 0:
            raise SpecError("numerics.seed", f"must be an integer ≥ 0, got {n.seed!r}")
        if not isinstance(n.threads, int) or n.threads < 1:
            raise SpecError("numerics.threads", f"must be an integer ≥ 1, got {n.threads!r}")
        if self.particle_count < min_particles:
            raise SpecError("geometry.vessel_diameter",
                            f"the cell holds only {self.particle_count} particles (< {min_particles}); "
                            "enlarge the cell or shrink the particles")
        gap = 2.0 * math.pi * g.head_radius / g.blade_count
        if gap < 2.0 * self.radius:
            raise SpecError("geometry.blade_count",
                            f"blades are {gap * 1e3:.2f} mm apart at the rim, less than a particle diameter "
                            f"({2e3 * self.radius:.2f} mm): too few particles for the head")
        return self


# ----------------------------------------------------------------------------- presets
#: Procedure presets: the paper's and the FT4 standard shear test of ASTM D7891.
PROCEDURES: dict[str, Procedure] = {
    "paper": Procedure(preshear_stress=15.0e3, shear_stresses=(9.0e3, 8.0e3, 7.0e3, 6.0e3)),
    "astm_d7891": Procedure(preshear_stress=9.0e3, shear_stresses=(7.0e3, 6.0e3, 5.0e3, 4.0e3, 3.0e3)),
}

#: Fidelity presets: cell size in particle diameters (H/D = 0.88 as the paper's 12k…200k beds),
#: time-step fraction, rotation and sampling, and as many one-diameter base ribs as the head has blades.
#: ``quick`` and ``tiny`` step at 0.15 Δt_crit: at 0.20, with the ribbed base and friction ≥ 0.9 on
#: particles or base, a particle's rotation went unstable (numba_dem, quick, μs = 0.9, seed 1: a
#: particle touching a rib oscillated with a sign flip every step, ×2–3 per step, and escaped;
#: LIGGGHTS lost atoms at tiny); sticking contacts stack the tangential and rolling springs' rotational
#: stiffness, and a rib adds one more wall contact, the stiffest kind (R* = r) ``paper`` is the reference paper's converged setting;
#: ``quick`` fits a 2-core machine; ``tiny`` is for tests and ``make run``.
#: Every preset preshears as the FT4 does, until τ/σ is steady (two windows of 0.1 rad within 5 %;
#: at least 0.3 rad, at most 1 rad): the former fixed preshears of 0.12–0.15 rad ended inside the
#: transient (at tiny τ/σ fell from 0.94 to a steady 0.55 over the first 0.45 rad of one preshear),
#: and with the blades riding on the bed's top (see INSERTION_STRESS_FRACTION) that made most of the
#: seed scatter. The shear windows of 0.3 rad hold the peaks that 0.12 rad cut off (README, How
#: noisy each preset is).
STEADY_PRESHEAR = {"preshear_rotation": 0.30, "preshear_max_rotation": 1.0, "steady_window": 0.1,
                   "steady_tolerance": 0.05}
FIDELITY_PRESETS: dict[str, dict[str, Any]] = {
    "paper": {
        "particles_per_diameter": 34.0, "height_ratio": 0.88, "blade_count": 18, "blade_height_d": 2.0, "base_ribs": 18,
        "procedure": {"rotation_rate": 0.5, **STEADY_PRESHEAR, "shear_rotation": 0.30,
                      "settle_time": 0.02, "peak_window": 0.01},
        "numerics": {"dt_fraction": 0.05, "sample_interval": 2.0e-4},
    },
    "quick": {
        "particles_per_diameter": 12.0, "height_ratio": 0.88, "blade_count": 12, "blade_height_d": 2.0, "base_ribs": 12,
        "procedure": {"rotation_rate": 5.0, **STEADY_PRESHEAR, "shear_rotation": 0.30,
                      "settle_time": 0.005, "peak_window": 0.03},
        "numerics": {"dt_fraction": 0.15, "sample_interval": 2.0e-4},
    },
    "tiny": {
        "particles_per_diameter": 9.0, "height_ratio": 0.88, "blade_count": 8, "blade_height_d": 2.0, "base_ribs": 8,
        "procedure": {"rotation_rate": 6.0, **STEADY_PRESHEAR, "shear_rotation": 0.30,
                      "settle_time": 0.004, "peak_window": 0.03},
        "numerics": {"dt_fraction": 0.15, "sample_interval": 2.0e-4},
    },
}


# ----------------------------------------------------------------------------- physics helpers
def critical_time_step(radius: float, density: float, reduced_modulus: float, stress: float) -> float:
    """The paper's eq. (1): Δt_crit = R (4/3)^(2/3) π^(1/3) √ρ σ0^(−1/6) Ẽ^(−1/3), s.

    Args:
        radius: R, m. density: ρ, kg/m³. reduced_modulus: Ẽ = E/(1−ν²), Pa. stress: σ0, Pa.
    """
    return radius * (4.0 / 3.0) ** (2.0 / 3.0) * math.pi ** (1.0 / 3.0) * math.sqrt(density) \
        * stress ** (-1.0 / 6.0) * reduced_modulus ** (-1.0 / 3.0)


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
            "pool seeds (seeds_per_point) or use a finer cell (README, How noisy each preset is)")


def steady_window_samples(rotation: np.ndarray, window: float) -> int:
    """Samples in one steady-state window of ``window`` rad: window / (rotation per sample),
    rounded, at least 1; ``rotation`` (rad, shape (n,), n ≥ 2) is a step's record."""
    rot = np.asarray(rotation, dtype=float)
    per_sample = (rot[-1] - rot[0]) / max(rot.size - 1, 1)
    return max(1, int(round(window / per_sample))) if per_sample > 0 else 1


def preshear_drift(rotation: np.ndarray, shear_stress: np.ndarray, normal_stress: np.ndarray,
                   window: float) -> float:
    """How far from steady a preshear ended: the relative difference of τ/σ (mean τ over mean σ)
    between the last M samples and the M before them, |m_last − m_before| / |m_last|, with M the
    samples in ``window`` rad (:func:`steady_window_samples`); NaN when there are fewer than 2M.

    Args:
        rotation: head rotation since the step's start, shape (n,), rad, evenly sampled.
        shear_stress, normal_stress: τ and σ, shape (n,), Pa.
        window: width of each window, rad.

    Every backend stops a capped preshear (``Procedure.preshear_max_rotation``) by this quantity
    (numba_dem calls it, YADE's script carries a copy, LIGGGHTS' script evaluates the same window
    means with two ``fix ave/time``), checked on the schedule of :func:`steady_schedule`.
    """
    tau = np.asarray(shear_stress, dtype=float)
    if tau.size < 2:
        return math.nan
    m = steady_window_samples(rotation, window)
    if tau.size < 2 * m:
        return math.nan
    sig = np.asarray(normal_stress, dtype=float)
    m_last = float(np.sum(tau[-m:]) / np.sum(sig[-m:]))
    m_before = float(np.sum(tau[-2 * m:-m]) / np.sum(sig[-2 * m:-m]))
    return abs(m_last - m_before) / abs(m_last) if m_last != 0 else math.inf


#: the part of a fixed (uncapped) preshear taken as its steady state: the last 40 % of its samples
FIXED_PRESHEAR_STEADY_FRACTION = 0.4


def preshear_steady_part(rotation: np.ndarray, procedure: "Procedure") -> slice:
    """The samples of a preshear (``rotation`` in rad since its start, shape (n,)) whose mean τ/σ is
    its steady value: everything after its first ``procedure.steady_window`` of rotation (the
    transient after the head is loaded back to the preshear stress) for a preshear that runs until
    steady (``preshear_max_rotation`` set), else its last 40 % of samples.

    All the steady rotation is averaged, because what scatters is τ's own fluctuation from one
    stretch of rotation to the next, not the packing: at ``tiny`` (10 seeds, Table 1) a preshear's
    τ/σ scattered by 0.11 over its last 40 % and the mean of the four by 0.042; over all but its
    first 0.1 rad, 0.025 (``benchmarks/seed_noise.py``, which splits the scatter).
    """
    rot = np.asarray(rotation, dtype=float)
    n = rot.size
    fixed = slice(int((1.0 - FIXED_PRESHEAR_STEADY_FRACTION) * n), None)
    if procedure.preshear_max_rotation is None or n == 0:
        return fixed
    start = int(np.searchsorted(rot, procedure.steady_window, side="left"))
    return slice(start, None) if n - start >= max(2, n - fixed.start) else fixed


def steady_schedule(procedure: "Procedure", rotation_per_sample: float) -> tuple[int, int, int, int]:
    """When a backend checks a capped preshear for steadiness, in samples of ``rotation_per_sample``
    rad: (first check, last sample, window M, check every). The first check comes after
    max(the minimum rotation, 2M) samples, then one every max(1, M // 5) samples until the cap;
    every backend follows it, so the same record stops at the same sample."""
    n_min = max(2, int(math.ceil(procedure.preshear_rotation / rotation_per_sample - 1e-9)))
    cap = procedure.preshear_max_rotation
    n_max = n_min if cap is None else max(n_min, int(math.ceil(cap / rotation_per_sample - 1e-9)))
    m = max(1, int(round(procedure.steady_window / rotation_per_sample)))
    return min(max(n_min, 2 * m), n_max), n_max, m, max(1, m // 5)


def running_mean_width(rotation: np.ndarray, window: float) -> int:
    """Samples in the running mean of :func:`find_peak`: ``window`` (rad) over the rotation per
    sample of ``rotation`` (rad, shape (n,)), rounded, between 1 and n."""
    rot = np.asarray(rotation, dtype=float)
    step = (rot[-1] - rot[0]) / max(rot.size - 1, 1) if rot.size else 0.0
    width = max(1, int(round(window / step))) if step > 0 else 1
    return min(width, max(rot.size, 1))


def stress_at_peak(rotation: np.ndarray, normal_stress: np.ndarray, window: float, centre: int) -> float:
    """σ (Pa) over the same running-mean window as the peak found at sample ``centre`` by
    :func:`find_peak`: the mean of ``normal_stress`` (shape (n,)) over those samples. (A single
    sample's σ, which in a 600-particle bed swings by ±10 % from one sample to the next, put
    0.08 of seed scatter on the mean peak τ/σ at ``tiny`` where the window's mean put 0.045.)"""
    if centre < 0:
        return float("nan")
    width = running_mean_width(rotation, window)
    start = max(0, centre - width // 2)
    return float(np.mean(np.asarray(normal_stress, dtype=float)[start:start + width]))


def find_peak(rotation: np.ndarray, shear_stress: np.ndarray, window: float) -> tuple[float, int, float]:
    """The peak of a shear step: the maximum of a running mean of width ``window`` (rad).

    Args:
        rotation: head rotation since the step's start, shape (n,), rad, non-decreasing.
        shear_stress: τ, shape (n,), Pa.
        window: width of the running mean, rad.

    Returns:
        (τ_peak in Pa, index of the peak sample, position of the peak as a fraction of the
        step's rotation: near 1 means the window was too short to pass the peak).
    """
    rot = np.asarray(rotation, dtype=float)
    tau = np.asarray(shear_stress, dtype=float)
    if rot.size == 0:
        return float("nan"), -1, float("nan")
    span = rot[-1] - rot[0]
    width = running_mean_width(rot, window)
    kernel = np.ones(width) / width
    smooth = np.convolve(tau, kernel, mode="valid")
    i = int(np.argmax(smooth))
    centre = i + width // 2
    position = float((rot[centre] - rot[0]) / span) if span > 0 else 1.0
    return float(smooth[i]), centre, position


# ----------------------------------------------------------------------------- results
#: a step whose mean measured σ is below this fraction of its target lost the bed (the servo let the
#: head lift off): the simulation is a failure, not a result (seen: LIGGGHTS' PI servo at μr = 0)
LOST_BED_FRACTION = 0.5


@dataclass(frozen=True)
class StepRecord:
    """Time series of one preshear or shear step, each array shape (n,).

    Attributes:
        kind: "preshear" | "shear".
        target_stress: σ the servo holds, Pa.
        time: s since the start of the test. rotation: head rotation since the step's start, rad.
        shear_stress: τ from the head torque, Pa. normal_stress: σ measured on the head, Pa.
        bed_height: height of the head's lower face (blade tips excluded) above the base, m.
        base_spin: mean angular velocity about the cell's axis of the particles in the layer just
            above the base (just above the ribs' tops where the base has ribs: centres within one
            particle diameter of it), rad/s; compared with the head's rotation rate it says whether
            the bed slid on its base (:func:`base_slip`). Empty where a backend did not record it.
    """

    kind: str
    target_stress: float
    time: np.ndarray
    rotation: np.ndarray
    shear_stress: np.ndarray
    normal_stress: np.ndarray
    bed_height: np.ndarray
    base_spin: np.ndarray = field(default_factory=lambda: np.empty(0))

    CHANNELS = ("time", "rotation", "shear_stress", "normal_stress", "bed_height", "base_spin")


@dataclass(frozen=True)
class Provenance:
    """Who made a result, and how."""

    backend: str
    engine_version: str
    spec_hash: str
    seed: int
    wall_time: float
    particle_count: int
    threads: int = 1
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ShearTestResult:
    """A whole shear test: the steps' time series and what is read off them.

    Arrays indexed by shear step k (shape (k,)): ``peak_shear_stress`` (Pa), ``peak_normal_stress``
    (σ measured at the peak: its mean over the peak's running-mean window, Pa; :func:`stress_at_peak`),
    ``target_normal_stress`` (Pa), ``peak_position`` (fraction of the
    window), ``bulk_density`` (after the preceding preshear, kg/m³), ``preshear_shear_stress``
    (steady τ of the preceding preshear, Pa), ``inertial_number``, ``preshear_rotation`` (how far
    the preceding preshear turned, rad) and ``preshear_drift`` (how far from steady it ended,
    :func:`preshear_drift`; NaN where it was shorter than two steady windows). The last two are
    empty in results stored before they existed.
    """

    steps: tuple[StepRecord, ...]
    peak_shear_stress: np.ndarray
    peak_normal_stress: np.ndarray
    target_normal_stress: np.ndarray
    peak_position: np.ndarray
    bulk_density: np.ndarray
    preshear_shear_stress: np.ndarray
    preshear_normal_stress: np.ndarray
    inertial_number: np.ndarray
    provenance: Provenance
    warnings: tuple[str, ...] = ()
    preshear_rotation: np.ndarray = field(default_factory=lambda: np.empty(0))
    preshear_drift: np.ndarray = field(default_factory=lambda: np.empty(0))

    @classmethod
    def from_steps(cls, spec: ShearCellSpec, steps: list[StepRecord], bulk_density: list[float],
                   provenance: Provenance, warnings: list[str] | None = None) -> "ShearTestResult":
        """Read peaks, preshear steady values and inertial numbers off the steps, the same way for
        every backend. ``bulk_density[k]`` is the bed's density after the k-th preshear (kg/m³)."""
        warns = list(warnings or [])
        for k, s in enumerate(steps):
            if s.normal_stress.size and not np.mean(s.normal_stress) >= LOST_BED_FRACTION * s.target_stress:
                raise SimulationFailed(
                    f"the head lost the bed: {s.kind} step {k} held a mean σ of {np.mean(s.normal_stress):.0f} Pa "
                    f"against its target {s.target_stress:.0f} Pa (below {LOST_BED_FRACTION:.0%}); its peaks "
                    "would mean nothing", kind="invalid")
        shear = [s for s in steps if s.kind == "shear"]
        pre = [s for s in steps if s.kind == "preshear"]
        peaks, sig, pos, inert, tau_pre, sig_pre = [], [], [], [], [], []
        for k, s in enumerate(shear):
            tau_p, i, where = find_peak(s.rotation, s.shear_stress, spec.procedure.peak_window)
            peaks.append(tau_p)
            sig.append(stress_at_peak(s.rotation, s.normal_stress, spec.procedure.peak_window, i))
            pos.append(where)
            inert.append(inertial_number(spec, s.target_stress))
            if where > 0.95:
                warns.append(f"shear step {k} (σ = {s.target_stress:.0f} Pa): peak at the window's end "
                             f"({where:.2f}); the shear rotation may be too short")
        proc = spec.procedure
        pre_rot, drift = [], []
        for k, s in enumerate(pre):
            tail = preshear_steady_part(s.rotation, proc)
            tau_pre.append(float(np.mean(s.shear_stress[tail])) if s.shear_stress.size else float("nan"))
            sig_pre.append(float(np.mean(s.normal_stress[tail])) if s.normal_stress.size else float("nan"))
            pre_rot.append(float(s.rotation[-1]) if s.rotation.size else float("nan"))
            drift.append(preshear_drift(s.rotation, s.shear_stress, s.normal_stress, proc.steady_window))
        if proc.preshear_max_rotation is not None:
            unsteady = [k for k, d in enumerate(drift) if not d <= proc.steady_tolerance]
            if unsteady:
                warns.append(
                    f"{len(unsteady)} of {len(pre)} preshears ended before τ/σ was steady (preshear "
                    + ", ".join(f"{k}: {pre_rot[k]:.2f} rad, drift {drift[k]:.1%}" for k in unsteady)
                    + f"; criterion: ≤ {proc.steady_tolerance:.1%} between two windows of {proc.steady_window} rad, "
                    f"cap procedure.preshear_max_rotation = {proc.preshear_max_rotation} rad); raise the cap")
        slips = [base_slip(s, spec.procedure.rotation_rate) for s in shear]
        slipped = [(k, v) for k, v in enumerate(slips) if v >= BASE_SPIN_SLIP_FRACTION]
        load = steady_base_load(spec, shear, bulk_density)
        if slipped:
            worst = max(v for _, v in slipped)
            warns.append(f"the bed slid on the base: its bottom layer turned at up to {worst:.0%} of the head's rate "
                         f"in {len(slipped)} of {len(shear)} shear steps (≥ {BASE_SPIN_SLIP_FRACTION:.0%}), so τ "
                         "measures the base more than the powder; give the base (more, higher) ribs "
                         "(geometry.base_ribs, geometry.rib_height) or more friction (geometry.base_friction)")
        elif load >= BASE_SLIP_FRACTION and not any(np.isfinite(slips)):
            mu_base, _ = spec.effective_base_friction()
            warns.append(f"the bed slid on the base: the steady τ of the shear steps reached {load:.0%} of what the "
                         f"flat base (μ = {mu_base:.3g}) can hold, so τ measures the base's friction more than the "
                         "powder's strength; give the base ribs (geometry.base_ribs) or more friction "
                         "(geometry.base_friction)")
        odd = locus_warning(np.asarray([s.target_stress for s in shear], float), np.asarray(peaks, float))
        if odd is not None:
            warns.append(odd)
        i_max = max(inert, default=0.0)
        if i_max > 1e-2:
            warns.append(f"inertial number up to {i_max:.1e} > 1e-2: the shear was not quasi-static; "
                         "lower procedure.rotation_rate")
        n = len(shear)
        return cls(
            steps=tuple(steps),
            peak_shear_stress=np.asarray(peaks, dtype=float),
            peak_normal_stress=np.asarray(sig, dtype=float),
            target_normal_stress=np.asarray([s.target_stress for s in shear], dtype=float),
            peak_position=np.asarray(pos, dtype=float),
            bulk_density=np.asarray(bulk_density[:n], dtype=float),
            preshear_shear_stress=np.asarray(tau_pre[:n], dtype=float),
            preshear_normal_stress=np.asarray(sig_pre[:n], dtype=float),
            inertial_number=np.asarray(inert, dtype=float),
            provenance=provenance,
            warnings=tuple(warns),
            preshear_rotation=np.asarray(pre_rot[:n], dtype=float),
            preshear_drift=np.asarray(drift[:n], dtype=float),
        )

    @property
    def base_slip(self) -> np.ndarray:
        """Per shear step, the bottom layer's spin over the head's rate (:func:`base_slip`), shape
        (k,); NaN where the backend did not record it."""
        rate = self._rotation_rate()
        return np.asarray([base_slip(s, rate) for s in self.steps if s.kind == "shear"], dtype=float)

    def _rotation_rate(self) -> float:
        """The head's rotation rate, rad/s, read off the first step's time series."""
        for s in self.steps:
            if s.rotation.size >= 2 and s.time[-1] > s.time[0]:
                return float((s.rotation[-1] - s.rotation[0]) / (s.time[-1] - s.time[0]))
        return math.nan

    def is_finite(self) -> bool:
        """True when every peak and measured σ is a finite number."""
        return bool(np.all(np.isfinite(self.peak_shear_stress)) and np.all(np.isfinite(self.peak_normal_stress)))

    def yield_locus(self, against: Literal["target", "measured"] = "target") -> YieldLocus:
        """Fit the locus against the servo's target σ (the paper's way) or the σ measured at each peak."""
        sigma = self.target_normal_stress if against == "target" else self.peak_normal_stress
        return YieldLocus.fit(sigma, self.peak_shear_stress)
