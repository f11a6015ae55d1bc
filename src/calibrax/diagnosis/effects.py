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
        def apply(self, spec, values): return spec.replace(geometry={"base_friction": values["base_friction"]})
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
        path: the spec field it sets, dotted (``geometry.wall_friction``), for the report.
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


Prior = UniformPrior | TruncatedNormalPrior


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


class WallFriction(_Builtin):
    """Sliding friction between the particles and the vessel's lateral wall (the paper's model has a
    frictionless wall). The FT4 wall friction test measures it: a ``wall_friction_angle_deg`` in the
    experiment's header becomes the prior, tan(φ_w) ± 0.05 (the spread of repeated wall friction
    tests), instead of a flat one over 0–0.6."""

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

    def apply(self, spec: "ShearCellSpec", values: dict[str, float]) -> "ShearCellSpec":
        return spec.replace(geometry={"wall_friction": float(values["wall_friction"])})


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
            return spec.replace(size_distribution={"kind": "mono", "sigma_log": 0.0})
        return spec.replace(size_distribution={"kind": "lognormal", "sigma_log": width})


class Cohesion(_Builtin):
    """Interparticle cohesion as a Bond number: the pull-off force of two particles over the mean
    contact force at the preshear stress (:mod:`calibrax.core.sheartest.cohesion`), uniform on 0–2;
    each backend converts it to its own cohesion parameter (numba_dem and LIGGGHTS: the SJKR energy
    density k at the calibrated E, ν and radius).

    The range spans free-flowing to very cohesive powders as the test sees them: the Bond number
    at the shear steps' 6–9 kPa is 1.7–2.5 times the preshear's, so Bo = 2 is a pull-off force five
    times the mean contact force at 6 kPa; sphere packings begin to shear differently near Bo = 1
    (Singh, Magnanimo, Saitoh and Luding, 2014, "Effect of cohesion on shear banding in
    quasistatic granular materials", Phys. Rev. E 90, 022202) and flow freely below about 0.1.
    The former range, SJKR k up to 3·10⁷ J/m³, reached only Bo ≈ 0.012–0.02 at E = 20–25 GPa,
    which no feature of the test could see."""

    name = "cohesion"
    label = "cohesion"
    capability = "cohesion"
    parameters = (EffectParameter("bond_number", "material.bond_number", 0.0, 2.0),)

    def apply(self, spec: "ShearCellSpec", values: dict[str, float]) -> "ShearCellSpec":
        return spec.replace(material={"bond_number": float(values["bond_number"]), "cohesion_energy_density": 0.0})


BUILTIN_EFFECTS = (WallFriction, SizeDistribution, Cohesion)


@hookimpl
def calibrax_effects() -> list[type]:
    return list(BUILTIN_EFFECTS)
