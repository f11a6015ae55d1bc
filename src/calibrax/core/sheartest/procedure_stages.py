"""The shear test as data: a tuple of frozen stages, and :func:`shear_test_stages`, the FT4 test of a
:class:`~calibrax.core.sheartest.spec.ShearCellSpec` written as one.

A stage says *what* the head does (pour, compress, insert the blades, consolidate, settle, rotate)
and under which normal stress; *how* (time steps, the servo, the checks) is the interpreter's
(:mod:`calibrax.core.sheartest.stage_runner`), and the engine's only through
:class:`~calibrax.core.sheartest.engine_interface.ShearCellEngine`. Rates, times and tolerances a
stage does not carry are the spec's procedure's (``rotation_rate``, ``settle_time``,
``consolidation_min_time``, ``steady_window`` …) and the shared rules of
:mod:`calibrax.core.sheartest.stages`.

Units: stresses in Pa (normal stress the servo holds on the head, σ = F / (π R_head²)), rotations in
rad (counted from 0 at the stage's start).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Union

from calibrax.core.sheartest.spec import ShearCellSpec


@dataclass(frozen=True)
class Pour:
    """Pour the packing under boosted gravity with the pour's low friction until it is still, then
    switch to the material's friction and normal gravity (:mod:`~calibrax.core.sheartest.stages`:
    POUR_GRAVITY, POUR_FRICTION, POUR_SPEED)."""


@dataclass(frozen=True)
class Compress:
    """The FT4 compressibility ramp: the head as a flat piston (blades retracted), placed on the bed,
    holds each of ``stresses`` (Pa, increasing) without turning until the bed has settled; the bed's
    height is recorded at each."""

    stresses: tuple[float, ...]


@dataclass(frozen=True)
class InsertBlades:
    """Place the head with its blade tips above the bed and take the turning blades into it under
    INSERTION_STRESS_FRACTION of ``stress`` (Pa, the consolidation stress the servo is tuned for)
    with the insertion's low friction."""

    stress: float


@dataclass(frozen=True)
class Consolidate:
    """Hold ``stress`` (Pa) while turning at the rotation rate, at least the procedure's
    ``consolidation_min_time`` and until the head has stopped sinking (at most
    ``consolidation_time_limit``)."""

    stress: float


@dataclass(frozen=True)
class Settle:
    """Turn the head back until its torque has relaxed (at most UNLOAD_MAX_ROTATION rad), then hold
    ``stress`` (Pa) without turning for the procedure's ``settle_time``."""

    stress: float


@dataclass(frozen=True)
class Rotate:
    """Turn the head by ``rotation`` (rad) at the rotation rate under ``stress`` (Pa), recording a
    :class:`~calibrax.core.sheartest.result.StepRecord` of ``kind`` ("preshear" | "shear"). With
    ``until_steady`` (and a procedure with ``preshear_max_rotation``) go on until τ/σ is steady or
    the cap."""

    kind: Literal["preshear", "shear"]
    stress: float
    rotation: float
    until_steady: bool = False


@dataclass(frozen=True)
class Fork:
    """Run ``stages`` on a copy of the state, then put the state back as it was before them (their
    records are kept): the compressibility ramp runs on the poured bed's copy, as the FT4 tests a
    fresh sample."""

    stages: tuple["Stage", ...]


Stage = Union[Pour, Compress, InsertBlades, Consolidate, Settle, Rotate, Fork]


def shear_test_stages(spec: ShearCellSpec) -> tuple[Stage, ...]:
    """The FT4 shear test of ``spec``: pour; the compressibility ramp on a copy of the poured bed
    (when ``procedure.compressibility_stresses`` is set); blades in and consolidation at the
    preshear stress; then for each shear stress σ_k: settle back at the preshear stress (k > 0),
    preshear until steady, settle at σ_k, shear. With ``procedure.branches``: one preshear until
    steady, then each σ_k's settle and shear on a copy of the presheared bed (a :class:`Fork`)."""
    p = spec.procedure
    stages: list[Stage] = [Pour()]
    if p.compressibility_stresses:
        stages.append(Fork((Compress(tuple(p.compressibility_stresses)),)))
    stages += [InsertBlades(p.preshear_stress), Consolidate(p.preshear_stress)]
    if p.branches:
        stages.append(Rotate("preshear", p.preshear_stress, p.preshear_rotation, until_steady=True))
        stages += [Fork((Settle(sigma), Rotate("shear", sigma, p.shear_rotation))) for sigma in p.shear_stresses]
        return tuple(stages)
    for k, sigma in enumerate(p.shear_stresses):
        if k > 0:
            stages.append(Settle(p.preshear_stress))
        stages.append(Rotate("preshear", p.preshear_stress, p.preshear_rotation, until_steady=True))
        stages.append(Settle(sigma))
        stages.append(Rotate("shear", sigma, p.shear_rotation))
    return tuple(stages)
