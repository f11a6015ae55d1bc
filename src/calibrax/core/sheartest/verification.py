"""The contract of a backend's analytic checks (``calibrax crosscheck``'s micro level).

A backend proves its contact law on cases with a known answer (:mod:`calibrax.core.sheartest.analytic`): a
head-on collision of two spheres, a sphere sliding on the base, a sphere spinning on it against
rolling resistance. It offers them as a class implementing :class:`Verification`, registered
through the ``calibrax_verifications`` hook like any other plugin, whose ``name`` is the simulator
it verifies::

    class MyVerification:
        name = "my_backend"                      # the simulator's name
        known_differences = {}                   # {(case method, quantity): why}, see below

        def two_sphere_collision(self, material: MicroMaterial) -> dict[str, float]:
            ...  # {"contact_time": s, "restitution": 1, "peak_overlap": m, ...}
        def sliding_on_base(self, material: MicroMaterial) -> dict[str, float]: ...
        def rolling_resistance(self, material: MicroMaterial) -> dict[str, float]: ...

    @hookimpl
    def calibrax_verifications():
        return [MyVerification]

A backend that models cohesion also offers ``cohesive_pull_off(material)``: two spheres, and a
sphere on the base, pulled apart at the Bond number :data:`PULL_OFF_BOND_NUMBER`, returning the
largest attraction (``pull_off_force``, ``wall_pull_off_force``, N) beside the law's
(``expected``, ``wall_expected``); the crosscheck runs the cases a verification has.

Each method runs its case at ``material`` (SI units) and returns {quantity: value}; the crosscheck
sets every backend's values side by side and calls them in agreement within 2 % of their mean.
``known_differences`` names the quantities in which the backend's contact law differs from the
others by construction (YADE's damping, say), with the reason the report prints.

A backend whose cases are plain functions taking the material's fields as keywords (numba_dem,
LIGGGHTS and YADE) derives from :class:`FunctionVerification` instead of writing the methods.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

from calibrax.core.sheartest.cohesion import BOND_REFERENCE_STRESS


@dataclass(frozen=True)
class MicroMaterial:
    """The material every micro case runs at: particle radius (m), E (Pa), ν, density (kg/m³),
    restitution e, sliding friction μs and rolling friction μr."""

    radius: float
    youngs_modulus: float
    poisson_ratio: float
    density: float
    restitution: float
    friction: float
    rolling_friction: float

    def replace(self, **changes: float) -> "MicroMaterial":
        """A copy with fields changed (the elastic collision sets ``restitution=1``)."""
        return dataclasses.replace(self, **changes)

    def keywords(self, *names: str) -> dict[str, float]:
        """{name: value} of the fields ``names``, as keyword arguments of a case function."""
        return {name: getattr(self, name) for name in names}


@runtime_checkable
class Verification(Protocol):
    """A backend's analytic checks; see the module's docstring for how to write and register one."""

    name: str
    known_differences: Mapping[tuple[str, str], str]

    def two_sphere_collision(self, material: MicroMaterial) -> dict[str, float]:
        """Two equal spheres meeting head-on at 0.5 m/s: contact time (s), restitution, peak
        overlap (m) and what else the backend measures."""
        ...

    def sliding_on_base(self, material: MicroMaterial) -> dict[str, float]:
        """A sphere launched along the base without spin until it rolls: the sliding time (s) and
        the deceleration against μs g."""
        ...

    def rolling_resistance(self, material: MicroMaterial) -> dict[str, float]:
        """A sphere spinning on the base against rolling resistance: the torque that stops it
        (N·m) against μr r m g."""
        ...


#: the micro cases the crosscheck runs: its label → (the :class:`Verification` method, the
#: material's fields it changes)
MICRO_CASES: dict[str, tuple[str, dict[str, float]]] = {
    "collision e=1": ("two_sphere_collision", {"restitution": 1.0}),
    "collision e=material": ("two_sphere_collision", {}),
    "sliding on base": ("sliding_on_base", {}),
    "rolling resistance": ("rolling_resistance", {}),
    "cohesive pull-off Bo=1": ("cohesive_pull_off", {}),
}
#: the Bond number of the cohesive pull-off case, and its reference stress (Pa): the Bond number's own
PULL_OFF_BOND_NUMBER = 1.0
PULL_OFF_STRESS = BOND_REFERENCE_STRESS


class FunctionVerification:
    """A :class:`Verification` made of a backend's case functions, each called with the material's
    fields it takes as keywords (its own defaults for everything else). Subclasses set ``name``,
    ``known_differences`` and the three functions."""

    name: ClassVar[str]
    known_differences: ClassVar[Mapping[tuple[str, str], str]] = {}
    collision: ClassVar[Callable[..., dict[str, float]]]
    sliding: ClassVar[Callable[..., dict[str, float]]]
    rolling: ClassVar[Callable[..., dict[str, float]]]

    ELASTIC = ("radius", "youngs_modulus", "poisson_ratio", "density", "restitution")

    def two_sphere_collision(self, material: MicroMaterial) -> dict[str, float]:
        return type(self).collision(**material.keywords(*self.ELASTIC))

    def sliding_on_base(self, material: MicroMaterial) -> dict[str, float]:
        return type(self).sliding(**material.keywords(*self.ELASTIC, "friction"))

    def rolling_resistance(self, material: MicroMaterial) -> dict[str, float]:
        return type(self).rolling(**material.keywords(*self.ELASTIC, "rolling_friction"))


class CohesiveFunctionVerification(FunctionVerification):
    """A :class:`FunctionVerification` of a backend with LIGGGHTS' SJKR cohesion: also the pull-off
    case, its function taking the SJKR energy density (J/m³) of the Bond number
    :data:`PULL_OFF_BOND_NUMBER` at the material."""

    pull_off: ClassVar[Callable[..., dict[str, float]]]

    def cohesive_pull_off(self, material: MicroMaterial) -> dict[str, float]:
        from calibrax.core.sheartest.cohesion import bond_number_energy_density

        k = bond_number_energy_density(PULL_OFF_BOND_NUMBER, material.radius, material.youngs_modulus,
                                       material.poisson_ratio, PULL_OFF_STRESS)
        return type(self).pull_off(energy_density=k, **material.keywords("radius", "youngs_modulus", "poisson_ratio",
                                                                          "density"))


__all__ = ["MicroMaterial", "Verification", "FunctionVerification", "CohesiveFunctionVerification", "MICRO_CASES",
           "PULL_OFF_BOND_NUMBER", "PULL_OFF_STRESS"]
