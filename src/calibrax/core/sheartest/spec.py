"""The backend-neutral spec of one FT4 shear test: material, size distribution, geometry,
procedure and numerics (SI units: Pa, m, s, rad, kg), and :class:`ShearCellSpec` that holds them.

Defaults are the reference paper's Table 1 material (E = 25 GPa, μs = 0.5, ν = 0.25, e = 0.3,
μr = 0.5, ρ = 3000 kg/m³, R = 0.9 mm) and its procedure (preshear 15 kPa; shear at 9, 8, 7, 6 kPa)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from calibrax.core.sheartest.fields import declared, set_paths
from calibrax.core.sheartest.presets import FIDELITY_PRESETS, PROCEDURES
from calibrax.core.sheartest.sector import bed_cross_section, core_radius, sector_width
from calibrax.core.sheartest.timestep import critical_time_step
from calibrax.core.sheartest.stages import CONSOLIDATION_LIMIT_FACTOR, CONSOLIDATION_LIMIT_ROTATION
from calibrax.errors import SpecError


#: (group, field) of spec fields added after specs were hashed, with their defaults
ADDED_SPEC_FIELDS: dict[tuple[str, str], Any] = {("material", "bond_number"): 0.0,
                                                  ("procedure", "compressibility_stresses"): (),
                                                  ("geometry", "sector"): 1,
                                                  ("geometry", "core_radius"): None,
                                                  ("procedure", "branches"): False,
                                                  ("procedure", "peak_noise_correction"): 0.0,
                                                  ("numerics", "device"): "cpu"}


#: the declarations that many fields share (:class:`~calibrax.core.sheartest.fields.FieldInfo`)
_LENGTH = {"unit": "m", "low": 0.0, "low_open": True, "display_scale": 1e3, "display_unit": "mm"}
_FRICTION = {"low": 0.0, "high": 5.0, "calibratable": True}
_ROTATION = {"unit": "rad", "low": 0.0, "low_open": True}


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
        bond_number: cohesion in physical units instead of k: the pull-off force of two particles
            of the nominal radius over the mean contact force at 15 kPa, whatever the procedure
            (:mod:`calibrax.core.sheartest.cohesion`); each backend converts it to its own
            cohesion parameter. 0 = none (the default); set this or ``cohesion_energy_density``.
    """

    youngs_modulus: float = declared(25.0e9, unit="Pa", symbol="E", low=1.0e5, high=1.0e13, calibratable=True,
                                     display_scale=1e-9, display_unit="GPa")
    poisson_ratio: float = declared(0.25, symbol="ν", low=0.0, high=0.5, high_open=True, calibratable=True)
    restitution: float = declared(0.3, symbol="e", low=0.0, high=1.0, low_open=True, calibratable=True)
    sliding_friction: float = declared(0.5, symbol="μs", low=0.0, high=5.0, calibratable=True)
    rolling_friction: float = declared(0.5, symbol="μr", low=0.0, high=5.0, calibratable=True)
    density: float = declared(3000.0, unit="kg/m³", symbol="ρ", low=1.0, high=1.0e5, calibratable=True)
    cohesion_energy_density: float = declared(0.0, unit="J/m³", symbol="k_coh", low=0.0, high=1.0e9,
                                              calibratable=True, display_scale=1e-3, display_unit="kJ/m³",
                                              capability="cohesion", off=0.0)
    bond_number: float = declared(0.0, symbol="Bo", low=0.0, high=100.0, calibratable=True, capability="cohesion",
                                  off=0.0)

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

    kind: Literal["mono", "lognormal", "table"] = declared("mono", unit="", capability="size_distribution",
                                                           off="mono")
    sigma_log: float = declared(0.0, symbol="σ_ln r", low=0.0, high=1.0, calibratable=True)
    min_ratio: float = declared(0.5, symbol="r_min/R", low=0.0, high=1.0, low_open=True)
    max_ratio: float = declared(2.0, symbol="r_max/R", low=1.0)
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
    ``sector`` k > 1 simulates 1/k of the cell with rotationally periodic faces and a frictionless
    core round the axis (:mod:`calibrax.core.sheartest.sector`); k divides the blade and rib counts.
    ``core_radius`` sets that core's radius (``None``: the sector's own, none for the full cell), at
    least the sector's and less than the hub's: a full cell with the core of a sector measures what
    the core alone changes.
    """

    vessel_diameter: float = declared(61.2e-3, **_LENGTH, symbol="D")
    fill_height: float = declared(53.9e-3, **_LENGTH, symbol="H")
    head_radius: float = declared(29.4e-3, **_LENGTH, symbol="R_h")
    blade_count: int = declared(18, symbol="n_b", low=1, integer=True)
    blade_height: float = declared(3.6e-3, **_LENGTH, symbol="h_b")
    hub_radius: float = declared(3.0e-3, **_LENGTH, symbol="r_hub")
    wall_friction: float = declared(0.0, **_FRICTION, symbol="μw", capability="wall_friction", off=0.0)
    wall_rolling_friction: float | None = declared(None, **_FRICTION, symbol="μr,w", optional=True)
    base_friction: float | None = declared(None, **_FRICTION, symbol="μb", optional=True)
    base_rolling_friction: float | None = declared(None, **_FRICTION, symbol="μr,b", optional=True)
    head_friction: float | None = declared(None, **_FRICTION, symbol="μh", optional=True)
    base_ribs: int = declared(18, symbol="n_r", low=0, integer=True, capability="base_ribs", off=0)
    rib_height: float = declared(1.8e-3, **_LENGTH, symbol="h_r")
    sector: int = declared(1, symbol="k", low=1, integer=True, capability="sector", off=1)
    core_radius: float | None = declared(None, **_LENGTH, symbol="r_core", optional=True, capability="sector",
                                         off=None)


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
        peak_noise_correction: how many s.d.s of the running mean's own noise
            (:func:`~calibrax.core.sheartest.peaks.window_noise`) the peak is read below the
            running mean's maximum; 0 (the default): the maximum itself, as the FT4 reads its
            (noise-free) torque. A DEM cell's τ fluctuates, the more the fewer particles carry the
            head (a 1/k sector's torque √k times the full cell's), and where the mean curve has no
            peak, a plateau, the maximum reads about 2.5 of these s.d.s above it with 0.3 rad of
            shear read in 0.03-rad windows (more with more windows): 2.5 then reads the mean
            curve's peak at every cell size (docs/explanation/sector.md).
        compressibility_stresses: the FT4 compressibility test's normal stresses, Pa, increasing,
            the last at most the preshear stress (e.g. 1, 2, 4, 6, 8, 10, 12, 15 kPa); () = no
            compressibility ramp (the default). When set, the head, its blades retracted (a flat
            piston, as the FT4's vented piston), compresses a copy of the poured bed through them
            without turning, holding each until it has stopped sinking; the shear test then runs
            on the poured bed as it was (the FT4 tests a fresh sample), and the result carries
            the ramp's bed height at each
            (:attr:`ShearTestResult.compression_height`; features ``compressibility_<σ>kPa``).
        branches: False (the default): the instrument's sequence, a preshear to steady state before
            every shear step. True: one preshear, and every shear step starts from a copy of the
            presheared bed (a :class:`~calibrax.core.sheartest.procedure_stages.Fork` each); every
            step's preshear values in the result are then that one preshear's. Every preshear of
            the sequence ends in the same steady state by the FT4's own criterion, so the branches
            cost one preshear instead of one per step (docs/explanation/sector.md measures both).
    """

    preshear_stress: float = declared(15.0e3, unit="Pa", symbol="σ_pre", low=0.0, low_open=True,
                                      display_scale=1e-3, display_unit="kPa")
    shear_stresses: tuple[float, ...] = (9.0e3, 8.0e3, 7.0e3, 6.0e3)
    rotation_rate: float = declared(1.0, unit="rad/s", symbol="ω", low=0.0, low_open=True)
    preshear_rotation: float = declared(0.30, **_ROTATION, symbol="φ_pre")
    preshear_max_rotation: float | None = declared(None, **_ROTATION, symbol="φ_pre,max", optional=True)
    steady_window: float = declared(0.1, **_ROTATION, symbol="Δφ_steady")
    steady_tolerance: float = declared(0.05, symbol="tol_steady", low=0.0, low_open=True)
    shear_rotation: float = declared(0.20, **_ROTATION, symbol="φ_shear")
    settle_time: float = declared(0.02, unit="s", symbol="t_settle", low=0.0)
    peak_window: float = declared(0.01, **_ROTATION, symbol="Δφ_peak")
    peak_noise_correction: float = declared(0.0, symbol="c_noise", low=0.0, high=5.0)
    compressibility_stresses: tuple[float, ...] = declared((), unit="", capability="compressibility_test", off=())
    branches: bool = declared(False, unit="", capability="branched_steps", off=False)

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
        device: where the backend steps the particles: ``cpu``, or ``cuda`` (a CUDA GPU; backends
            with the capability ``cuda``).
    """

    dt_fraction: float = declared(0.05, symbol="Δt/Δt_crit", low=0.0, high=1.0, low_open=True)
    stress_for_dt: float | None = declared(None, unit="Pa", symbol="σ0", low=0.0, low_open=True, optional=True)
    sample_interval: float = declared(2.0e-4, unit="s", symbol="Δt_sample", low=0.0, low_open=True)
    seed: int = declared(0, symbol="seed", low=0, integer=True)
    threads: int = declared(1, symbol="threads", low=1, integer=True)
    device: Literal["cpu", "cuda"] = declared("cpu", unit="", capability="cuda", off="cpu")


@dataclass(frozen=True)
class ShearCellSpec:
    """One FT4 shear test, complete and backend-neutral. Use :meth:`preset` to build one."""

    geometry: Geometry = field(default_factory=Geometry)
    material: Material = field(default_factory=Material)
    radius: float = declared(0.9e-3, **_LENGTH, symbol="R")
    size_distribution: SizeDistribution = field(default_factory=SizeDistribution)
    fill_solid_fraction: float = declared(0.60, symbol="φ_fill", low=0.3, high=0.74)
    procedure: Procedure = field(default_factory=Procedure)
    numerics: Numerics = field(default_factory=Numerics)
    name: str = "custom"

    # -- derived quantities ------------------------------------------------------------------
    @property
    def particles_per_diameter(self) -> float:
        """Cell diameter in particle diameters, D / (2R)."""
        return self.geometry.vessel_diameter / (2.0 * self.radius)

    @property
    def radius_range(self) -> tuple[float, float]:
        """(smallest, largest) particle radius the size distribution allows, m."""
        sd = self.size_distribution
        if sd.kind == "lognormal":
            return self.radius * sd.min_ratio, self.radius * sd.max_ratio
        if sd.kind == "table":
            return min(sd.radii), max(sd.radii)
        return self.radius, self.radius

    @property
    def sector_core_radius(self) -> float:
        """The smallest frictionless core the sector needs round the axis, m (0 for the full cell):
        :func:`calibrax.core.sheartest.sector.core_radius`."""
        r_min, r_max = self.radius_range
        return core_radius(self.geometry.sector, r_max, r_min)

    @property
    def core_radius(self) -> float:
        """Radius of the frictionless core round the axis, m: ``geometry.core_radius`` if set, else
        :attr:`sector_core_radius`."""
        return self.sector_core_radius if self.geometry.core_radius is None else self.geometry.core_radius

    @property
    def bed_cross_section(self) -> float:
        """The horizontal area the simulated particles fill, m²: π R² of the vessel, or the sector's
        share of it outside the core."""
        return bed_cross_section(self.geometry.sector, self.geometry.vessel_diameter / 2.0, self.core_radius)

    @property
    def particle_count(self) -> int:
        """Particles needed to fill the cell (or its sector) to ``fill_height`` at
        ``fill_solid_fraction``."""
        g = self.geometry
        v_cell = self.bed_cross_section * g.fill_height
        v_p = 4.0 / 3.0 * math.pi * self.radius**3 * self.size_distribution.mean_volume_factor(self.radius)
        return int(round(self.fill_solid_fraction * v_cell / v_p))

    @property
    def critical_time_step(self) -> float:
        """Δt_crit of the paper's eq. (1) at σ0 (``numerics.stress_for_dt`` or the preshear σ), s."""
        s0 = self.numerics.stress_for_dt or self.procedure.preshear_stress
        r_min, _ = self.radius_range
        return critical_time_step(r_min, self.material.density, self.material.reduced_modulus, s0)

    @property
    def time_step(self) -> float:
        """Δt = dt_fraction · Δt_crit, s."""
        return self.numerics.dt_fraction * self.critical_time_step

    def cell_words(self) -> str:
        """The simulated cell in words, for ``run --check``, ``status`` and the report: "143
        particles, 9.0 per diameter, a 1/4 sector (frictionless core 0.75 mm; 4.5 diameters wide at
        ⅔ R_head)" (:func:`~calibrax.core.sheartest.sector.sector_width`)."""
        words = f"{self.particle_count} particles, {self.particles_per_diameter:.1f} per diameter"
        k = self.geometry.sector
        if k > 1:
            width = sector_width(k, self.geometry.head_radius, 2.0 * self.radius)
            words += (f", a 1/{k} sector (frictionless core {self.core_radius * 1e3:.2f} mm; {width:.1f} diameters "
                      "wide at ⅔ R_head)")
        elif self.core_radius > 0:
            words += f", a frictionless core of {self.core_radius * 1e3:.2f} mm"
        return words

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

    def sjkr_energy_density(self) -> float:
        """The SJKR cohesion energy density k, J/m³, of a backend with LIGGGHTS' ``cohesion sjkr``
        law (numba_dem, LIGGGHTS): the material's k, or the k whose pull-off force between two
        particles of the nominal radius is ``bond_number`` times the mean contact force at
        :data:`~calibrax.core.sheartest.cohesion.BOND_REFERENCE_STRESS` (15 kPa) for every procedure
        (:func:`calibrax.core.sheartest.cohesion.bond_number_energy_density`)."""
        from calibrax.core.sheartest.cohesion import BOND_REFERENCE_STRESS, bond_number_energy_density

        m = self.material
        if m.bond_number > 0.0:
            return bond_number_energy_density(m.bond_number, self.radius, m.youngs_modulus, m.poisson_ratio,
                                              BOND_REFERENCE_STRESS)
        return m.cohesion_energy_density

    def is_cohesive(self) -> bool:
        """Whether the material has any cohesion (by k or by Bond number)."""
        return self.material.cohesion_energy_density > 0.0 or self.material.bond_number > 0.0

    # -- construction ------------------------------------------------------------------------
    @classmethod
    def preset(cls, fidelity: str = "quick", procedure: str = "paper", **overrides: Any) -> "ShearCellSpec":
        """Build a spec from a fidelity preset and a procedure preset.

        A fidelity preset states its rotation rate, or its inertial number at the preshear stress
        (``procedure.inertial_number``), from which the rate of the cell it builds is derived
        (:meth:`with_inertial_number`) after ``overrides`` are applied (a cell of other particles
        or another density gets its own rate).

        Args:
            fidelity: a key of :data:`FIDELITY_PRESETS` ("paper", "converged", "quick", "tiny").
            procedure: a key of :data:`PROCEDURES` ("paper", "astm_d7891", "ft4_3kpa").
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
            head_radius=diameter / 2.0 - p["rim_gap_d"] * d if "rim_gap_d" in p else 0.48 * diameter,
            blade_count=p["blade_count"],
            blade_height=p["blade_height_d"] * d,
            hub_radius=0.1 * diameter,
            base_ribs=p["base_ribs"],
            rib_height=d,
            sector=int(p.get("sector", 1)),
        )
        values = {**PROCEDURES[procedure], **p["procedure"]}
        inertial = values.pop("inertial_number", None)
        proc = Procedure(**values)
        numerics = Numerics(**p["numerics"])
        spec = cls(geometry=geometry, radius=radius, procedure=proc, numerics=numerics, name=fidelity)
        spec = spec.replace(**overrides)
        if inertial is not None:
            spec = spec.with_inertial_number(inertial)
        return spec

    def with_inertial_number(self, inertial: float) -> "ShearCellSpec":
        """A copy whose head turns at the rate that gives the inertial number ``inertial`` at the
        preshear stress (:func:`~calibrax.core.sheartest.physics.rotation_rate_for_inertial_number`;
        the shear steps, at lower σ, run at a higher I, ∝ 1/√σ)."""
        from calibrax.core.sheartest.physics import rotation_rate_for_inertial_number

        rate = rotation_rate_for_inertial_number(inertial, self.geometry.head_radius, self.procedure.preshear_stress,
                                                 self.material.density)
        return self.replace(procedure={"rotation_rate": rate})

    def with_values(self, values: dict[str, Any]) -> "ShearCellSpec":
        """A copy with each dotted path of ``values`` set (``{"geometry.wall_friction": 0.3,
        "material.sliding_friction": 0.4}``): how a campaign's point and a diagnosis's effect set
        the spec (:func:`~calibrax.core.sheartest.fields.set_paths`)."""
        return set_paths(self, values)

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
        """A short stable hash of the whole spec (seed included); a field added after specs were
        hashed (:data:`ADDED_SPEC_FIELDS`) counts only when it differs from its default, so that
        the hashes of every spec made before it stay as they were."""
        data = self.to_dict()
        for (group, name), default in ADDED_SPEC_FIELDS.items():
            if data.get(group, {}).get(name) == json.loads(json.dumps(default)):
                del data[group][name]
        blob = json.dumps(data, sort_keys=True).encode()
        return hashlib.sha256(blob).hexdigest()[:16]

    def validate(self, min_particles: int = 50) -> "ShearCellSpec":
        """Raise :class:`SpecError` naming the field and what is allowed; return self if valid."""
        from calibrax.core.sheartest.validation import validate_spec

        return validate_spec(self, min_particles)
