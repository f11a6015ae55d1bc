"""What each stage of :mod:`~calibrax.core.sheartest.procedure_stages` measured (one record type
per stage kind), and :func:`summarise`, which reads the fields of a
:class:`~calibrax.core.sheartest.result.ShearTestResult` and its provenance off a test's records."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Union

from calibrax.core.sheartest.steps import StepRecord


@dataclass(frozen=True)
class PourRecord:
    """``conditioned_bulk_density``: the poured bed's, kg/m³
    (:func:`~calibrax.core.sheartest.density.conditioned_bulk_density`); ``duration``: the pour
    proper (before the switch to the material's friction), s."""

    conditioned_bulk_density: float
    duration: float


@dataclass(frozen=True)
class CompressRecord:
    """``heights``: the head's lower face above the base at each stress of the ramp, m (shape as
    the stage's ``stresses``); ``settled``: whether each hold settled before its time limit."""

    heights: tuple[float, ...]
    settled: tuple[bool, ...]


@dataclass(frozen=True)
class InsertRecord:
    """``gap_radii``: the head's face above the poured bed's highest particle after the insertion,
    in particle radii (≤ INSERTION_TOLERANCE_RADII when the blades went in); ``duration``, s."""

    gap_radii: float
    duration: float


@dataclass(frozen=True)
class ConsolidateRecord:
    """``duration``, s; ``rotation``: how far the head turned, rad; ``normal_stress``: the last σ
    measured, Pa; ``settled``: whether the head stopped sinking before the time limit."""

    duration: float
    rotation: float
    normal_stress: float
    settled: bool


@dataclass(frozen=True)
class SettleRecord:
    """``turned_back``: the torque unload's rotation, rad; ``normal_stress``, ``shear_stress``: σ
    and τ over the last sample interval, Pa."""

    turned_back: float
    normal_stress: float
    shear_stress: float


@dataclass(frozen=True)
class RotateRecord:
    """``step``: the time series; ``bulk_density``: the bed's under the head at the end, kg/m³;
    ``sigma_error``: mean measured σ / target − 1."""

    step: StepRecord
    bulk_density: float
    sigma_error: float


@dataclass(frozen=True)
class ForkRecord:
    """The records of the forked stages, in order."""

    records: tuple["Record", ...]


Record = Union[PourRecord, CompressRecord, InsertRecord, ConsolidateRecord, SettleRecord, RotateRecord, ForkRecord]


@dataclass(frozen=True)
class StageSummary:
    """A test's records as the result's and the provenance's fields (SI units, as the records).

    ``steps`` every Rotate's StepRecord in order; ``bulk_density`` the bed's after each preshear;
    ``compression_height`` the ramp's heights (empty without one); ``sigma_errors`` per rotation."""

    steps: list[StepRecord] = field(default_factory=list)
    bulk_density: list[float] = field(default_factory=list)
    conditioned_bulk_density: float = math.nan
    compression_height: list[float] = field(default_factory=list)
    sigma_errors: list[float] = field(default_factory=list)
    consolidation_time: float = math.nan
    consolidation_rotation: float = math.nan
    insertion_gap: float = math.nan


def flatten(records) -> list:
    """The records with every ForkRecord replaced by its own records, in order."""
    out = []
    for rec in records:
        out += flatten(rec.records) if isinstance(rec, ForkRecord) else [rec]
    return out


def summarise(records) -> StageSummary:
    """Gather a test's records (forks included) into a :class:`StageSummary`. Every shear step is
    paired with the preshear before it: a shear step that follows another (the branches of one
    preshear, ``procedure.branches``) gets that preshear's record again, so that the result holds
    a preshear and a shear step per shear stress whatever the procedure."""
    s = StageSummary()
    values = {}
    preshear: RotateRecord | None = None
    previous = ""
    for rec in flatten(records):
        if isinstance(rec, RotateRecord):
            if rec.step.kind == "shear" and previous == "shear" and preshear is not None:
                s.steps.append(preshear.step)
                s.bulk_density.append(preshear.bulk_density)
            s.steps.append(rec.step)
            s.sigma_errors.append(rec.sigma_error)
            previous = rec.step.kind
            if rec.step.kind == "preshear":
                preshear = rec
                s.bulk_density.append(rec.bulk_density)
        elif isinstance(rec, CompressRecord):
            s.compression_height.extend(rec.heights)
        elif isinstance(rec, PourRecord):
            values["conditioned_bulk_density"] = rec.conditioned_bulk_density
        elif isinstance(rec, ConsolidateRecord):
            values["consolidation_time"], values["consolidation_rotation"] = rec.duration, rec.rotation
        elif isinstance(rec, InsertRecord):
            values["insertion_gap"] = rec.gap_radii
    return StageSummary(s.steps, s.bulk_density, compression_height=s.compression_height,
                       sigma_errors=s.sigma_errors, **values)
