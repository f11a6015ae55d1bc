"""Candidate unmodelled effects: what ``calibrax diagnose`` may add to a calibrated model.

An effect is a plugin class (hook ``calibrax_effects``) with a ``name`` users write
(``--effects wall_friction,cohesion``), a ``label`` for reports, the backend capability it needs
(:data:`calibrax.core.simulator.KNOWN_CAPABILITIES`), the spec parameters it adds
(:class:`EffectParameter`, each with its range and prior) and ``apply(spec, values)``, which
returns the spec with the effect switched on. Every parameter's ``off`` value is the model
without the effect, so "no effect" is the same model at ``off``.

A builtin effect needs a dozen lines; a plugin's looks the same::

    class BaseFriction:
        name, label, capability = "base_friction", "base friction", "base_ribs"
        parameters = (EffectParameter("base_friction", "geometry.base_friction", 0.1, 0.9, off=0.5),)
        def prior(self, experiment): return {p.name: UniformPrior(p.low, p.high) for p in self.parameters}
        def apply(self, spec, values): return spec.with_values({"geometry.base_friction": values["base_friction"]})
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from calibrax.core.hookspecs import hookimpl

if TYPE_CHECKING:  # pragma: no cover
    from calibrax.core.data.experiment import Experiment
    from calibrax.core.sheartest import ShearCellSpec


@dataclass(frozen=True)
class EffectParameter:
    """One parameter an effect adds.

    Attributes:
        name: the parameter's name in tables and the store (e.g. ``wall_friction``).
        path: the spec field it sets, dotted (``geometry.wall_friction``): the path a campaign
            calibrates it by too (``parameters: {geometry.wall_friction: ...}``).
        low, high: the range the diagnosis explores, natural units.
        unit: for tables and axes ("-": dimensionless).
        off: the value that switches the effect off (the calibrated model's value).
    """

    name: str
    path: str
    low: float
    high: float
    unit: str = "-"
    off: float = 0.0

    def scaled(self, value: float | np.ndarray) -> float | np.ndarray:
        """The value as a fraction of the range above ``off`` (0: off, 1: ``high``)."""
        return (np.asarray(value, dtype=float) - self.off) / (self.high - self.off)


@dataclass(frozen=True)
class UniformPrior:
    """Flat between ``low`` and ``high`` (natural units)."""

    low: float
    high: float

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """Quantile function: unit-interval samples, shape (n,), to values, shape (n,)."""
        return self.low + np.asarray(u) * (self.high - self.low)

    def describe(self) -> str:
        return f"uniform on [{self.low:g}, {self.high:g}]"


@dataclass(frozen=True)
class TruncatedNormalPrior:
    """A normal (``mean``, ``sd``) truncated to [``low``, ``high``]: a measured value with its error."""

    mean: float
    sd: float
    low: float
    high: float
    why: str = ""

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy import stats  # here, not at import: every simulation process loads the effects

        a, b = (self.low - self.mean) / self.sd, (self.high - self.mean) / self.sd
        return stats.truncnorm.ppf(np.clip(u, 1e-12, 1 - 1e-12), a, b, loc=self.mean, scale=self.sd)

    def describe(self) -> str:
        return f"normal {self.mean:.3g} ± {self.sd:.2g} on [{self.low:g}, {self.high:g}]" + (
            f" ({self.why})" if self.why else "")


@dataclass(frozen=True)
class LogUniformPrior:
    """Flat in the logarithm between ``low`` > 0 and ``high`` (natural units): a scale known only to
    its order of magnitude, each decade as likely as the next. ``why``: the range's sources."""

    low: float
    high: float
    why: str = ""

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """Quantile function: unit-interval samples, shape (n,), to values, shape (n,)."""
        return self.low * (self.high / self.low) ** np.asarray(u, dtype=float)

    def describe(self) -> str:
        return f"log-uniform on [{self.low:g}, {self.high:g}]" + (f" ({self.why})" if self.why else "")


Prior = UniformPrior | TruncatedNormalPrior | LogUniformPrior


@runtime_checkable
class Effect(Protocol):
    """A candidate unmodelled effect (see the module docstring)."""

    name: str
    label: str
    capability: str
    parameters: tuple[EffectParameter, ...]

    def prior(self, experiment: "Experiment") -> dict[str, Prior]:
        """The prior of each parameter; may use what the experiment measured besides the shear test."""
        ...

    def apply(self, spec: "ShearCellSpec", values: dict[str, float]) -> "ShearCellSpec":
        """The spec with the effect switched on at ``values`` ({parameter name: natural value})."""
        ...


class _Builtin:
    """Shared behaviour of the builtin effects: a flat prior over each parameter's range."""

    name: str
    label: str
    capability: str
    parameters: tuple[EffectParameter, ...]

    def prior(self, experiment: "Experiment") -> dict[str, Prior]:
        return {p.name: UniformPrior(p.low, p.high) for p in self.parameters}

    def apply(self, spec: "ShearCellSpec", values: dict[str, float]) -> "ShearCellSpec":
        """Each parameter's value set at its spec path, as a campaign sets a calibrated one
        (:meth:`~calibrax.core.sheartest.ShearCellSpec.with_values`)."""
        return spec.with_values({p.path: float(values[p.name]) for p in self.parameters})


class WallFriction(_Builtin):
    """Sliding friction between the particles and the vessel's lateral wall (the paper's model has a
    frictionless wall). The FT4 wall friction test measures it: a ``wall_friction_angle_deg`` in the
    experiment's header becomes the prior, tan(φ_w) ± 0.05 (the spread of repeated wall friction
    tests), instead of a flat one over 0–0.6. That range holds the wall friction angles of powders
    on steel and glass, about 5° to 30° (tan φ_w 0.09–0.58: Schulze, *Powders and Bulk Solids*,
    Springer 2008, ch. 3.3; Freeman 2007, "Measuring the flow properties of consolidated, conditioned
    and aerated powders", Powder Technol. 174, 25): a coefficient bounded on both sides by what is
    measured, so flat on it, its width charged in the evidence like every prior's."""

    name = "wall_friction"
    label = "lateral wall friction"
    capability = "wall_friction"
    parameters = (EffectParameter("wall_friction", "geometry.wall_friction", 0.0, 0.6),)
    MEASURED_SD = 0.05

    def prior(self, experiment: "Experiment") -> dict[str, Prior]:
        p = self.parameters[0]
        angle = getattr(experiment, "wall_friction_angle_deg", math.nan)
        if angle is not None and math.isfinite(angle):
            mu = math.tan(math.radians(angle))
            return {p.name: TruncatedNormalPrior(mu, self.MEASURED_SD, p.low, p.high,
                                                 f"the experiment's wall friction angle {angle:g}°")}
        return super().prior(experiment)


class SizeDistribution(_Builtin):
    """A log-normal spread of particle radii about the calibrated radius (the paper's particles are
    monosized): σ of ln r, uniform on 0–0.5.

    The range spans the sieved and classified powders an FT4 is used on: σ = 0.1 is a narrow sieve
    cut (d90/d10 = 1.3), 0.25 a classified powder (1.9), 0.5 a milled one (d90/d10 = 3.6 before the
    radii are clipped to 0.5–2 × the median, ``size_distribution.min_ratio``/``max_ratio``). Wider
    spans need more particles per cell than the presets have. What to expect (Nguyen et al. 2015,
    Azéma, Linero, Estrada and Lizcano 2017, sheared sphere packings of growing size span): the
    shear strength hardly depends on the span, the packing fraction rises with it, weakly below
    about 40 % spread, so the effect shows in the bulk density and its change with stress more than
    in the yield locus."""

    name = "size_distribution"
    label = "size-distribution width"
    capability = "size_distribution"
    parameters = (EffectParameter("sigma_log", "size_distribution.sigma_log", 0.0, 0.5),)

    def apply(self, spec: "ShearCellSpec", values: dict[str, float]) -> "ShearCellSpec":
        width = float(values["sigma_log"])
        if width <= 1e-6:
            return spec.with_values({"size_distribution.kind": "mono", "size_distribution.sigma_log": 0.0})
        return spec.with_values({"size_distribution.kind": "lognormal", "size_distribution.sigma_log": width})


class Cohesion(_Builtin):
    """Interparticle cohesion as a Bond number: the pull-off force of two particles over the mean
    contact force at the preshear stress (:mod:`calibrax.core.sheartest.cohesion`); each backend
    converts it to its own cohesion parameter (numba_dem and LIGGGHTS: the SJKR energy density k at
    the calibrated E, ν and radius). The design explores 0–2; the prior is log-uniform on
    ``BOND_RANGE``, 0.01–2, because what a powder's Bond number can be is known to its order of
    magnitude only, and a flat prior up to 2 would give the cohesive decade 90 % of the weight and
    let cohesion absorb a misfit of any kind (issue 48).

    The range, at the preshear's 15 kPa, where the mean contact force is about σ d² (Rumpf's
    estimate, within a factor 2 for random packings): 8·10⁻⁵ N at d = 75 µm, 1.5·10⁻⁶ N at 10 µm.

    * **Van der Waals**, F = A R / (12 z₀²) with A ≈ 10⁻¹⁹ J and z₀ ≈ 0.4 nm (Israelachvili,
      *Intermolecular and Surface Forces*, 3rd ed. 2011, ch. 13; Seville, Willett and Knight 2000,
      "Interparticle forces in fluidisation: a review", Powder Technol. 113, 261): 2·10⁻⁶ N at
      75 µm, 3·10⁻⁷ N at 10 µm, so Bo ≈ 0.02 to 0.2 for smooth spheres, and 10–100 times less with
      the asperities real particles have (Castellanos 2005, Adv. Phys. 54, 263): the range's low
      end, where no feature of the test sees cohesion (the former SJKR range reached Bo 0.012–0.02
      and changed nothing measurable).
    * **Liquid bridges** at high humidity, F ≈ 2πγR with γ = 0.072 N/m (Seville et al. 2000):
      1.7·10⁻⁵ N at 75 µm, 2.3·10⁻⁶ N at 10 µm, so Bo ≈ 0.2 to 1.5: the range's high end.
    * Sphere packings shear differently from about Bo = 1 (Singh, Magnanimo, Saitoh and Luding
      2014, "Effect of cohesion on shear banding in quasistatic granular materials", Phys. Rev. E 90,
      022202); the shear steps' 6–9 kPa raise the Bond number 1.7–2.5 times over the preshear's.
    """

    name = "cohesion"
    label = "cohesion"
    capability = "cohesion"
    parameters = (EffectParameter("bond_number", "material.bond_number", 0.0, 2.0),)
    #: the prior's range of the Bond number at the preshear stress (see the class docstring)
    BOND_RANGE = (0.01, 2.0)

    def prior(self, experiment: "Experiment") -> dict[str, Prior]:
        low, high = self.BOND_RANGE
        return {"bond_number": LogUniformPrior(low, high, "van der Waals to liquid bridges, 10–75 µm, at 15 kPa")}

    def apply(self, spec: "ShearCellSpec", values: dict[str, float]) -> "ShearCellSpec":
        return spec.with_values({"material.bond_number": float(values["bond_number"]),
                                 "material.cohesion_energy_density": 0.0})


BUILTIN_EFFECTS = (WallFriction, SizeDistribution, Cohesion)


@hookimpl
def calibrax_effects() -> list[type]:
    return list(BUILTIN_EFFECTS)
