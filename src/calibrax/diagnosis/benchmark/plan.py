"""Which cases a benchmark makes: classes, magnitudes, truth parameters, truth backends and seeds.

The DEM level makes ``per_class`` cases of every class on the model's own backend (a listed
effect's cases cycle through small, medium and large) and, for each class in
``other_backends``, as many again on that backend (by default the wall-friction class on LIGGGHTS:
the nearer stand-in for a real powder, whose contact implementation, packing and servo differ
from numba_dem's). Truth
parameters cycle through :data:`TRUTH_PARAMS`, inside the model's plausible region.
"""

from __future__ import annotations

from dataclasses import dataclass

from calibrax.core.data.pseudo import EXPERIMENT_SEED_BASE
from calibrax.core.studies.simulation_setup import point_spec
from calibrax.core.sheartest import ShearCellSpec
from calibrax.diagnosis.benchmark.cases import (CLASS_MIXED, CLASS_NONE, CLASS_UNLISTED, MAGNITUDES, OTHER_CLASSES,
                                                ROLLING_FRICTION_TRUTH, CaseLabel, RollingFriction, expected_answer,
                                                listed_and_unlisted, opaque_ids)
from calibrax.diagnosis.benchmark.model import BenchmarkModel
from calibrax.diagnosis.design import SEED_BASE

#: the calibrated parameters the DEM level's cases are made at, in turn
TRUTH_PARAMS = ({"youngs_modulus": 2.0e10, "sliding_friction": 0.35},
                {"youngs_modulus": 1.4e10, "sliding_friction": 0.28},
                {"youngs_modulus": 3.0e10, "sliding_friction": 0.42})
LEVELS = ("small", "medium", "large")
#: replicates of every case (an FT4 user repeats a test three times)
REPLICATES = 3
#: the oracle's seeds: the model with the true effect at its true magnitude, on the diagnosing backend
ORACLE_SEEDS = 3
#: seeds of the truths start here (experiment seeds), of the oracles there (simulation seeds)
TRUTH_SEED_BASE = EXPERIMENT_SEED_BASE + 20_000
ORACLE_SEED_BASE = SEED_BASE + 500_000


@dataclass(frozen=True)
class PlannedCase:
    """A case to make: its label (the truth) and the seeds of its replicates and of its oracle."""

    label: CaseLabel
    seeds: tuple[int, ...]
    oracle_seeds: tuple[int, ...]


def listed_classes(model: BenchmarkModel) -> list[tuple[str, str]]:
    """(effect name, its parameter name) of every candidate the benchmark has magnitudes for."""
    return [(e.name, e.parameters[0].name) for e in model.effects() if e.parameters[0].name in MAGNITUDES]


def plan_dem(model: BenchmarkModel, per_class: int = 3, other_backends: dict[str, tuple[str, ...]] | None = None,
             seed: int = 0) -> list[PlannedCase]:
    """The DEM level's cases (see the module docstring), with opaque ids."""
    other_backends = {"liggghts": ("wall_friction",)} if other_backends is None else other_backends
    # class, level, backend, params, effects, expected answer
    rows: list[tuple[str, str, str, dict[str, float], dict[str, float], str]] = []
    mixed = listed_and_unlisted(listed_classes(model))

    def add(backend: str, klass: str) -> None:
        for k in range(per_class):
            params = dict(TRUTH_PARAMS[k % len(TRUTH_PARAMS)])
            if klass == CLASS_NONE:
                rows.append((klass, "", backend, params, {}, expected_answer(klass)))
            elif klass == CLASS_UNLISTED:
                rows.append((klass, "rolling friction", backend, params, {"rolling_friction": ROLLING_FRICTION_TRUTH},
                             expected_answer(klass)))
            elif klass == CLASS_MIXED:
                name, effects = mixed[k % len(mixed)]
                rows.append((klass, f"{name} + rolling friction", backend, params, dict(effects), name))
            else:
                pname = dict(listed_classes(model))[klass]
                level = LEVELS[k % len(LEVELS)]
                rows.append((klass, level, backend, params, {pname: MAGNITUDES[pname][level]}, klass))

    classes = [name for name, _ in listed_classes(model)] + [CLASS_NONE, CLASS_UNLISTED] + (
        [CLASS_MIXED] if mixed else [])
    for klass in classes:
        add(model.simulator, klass)
    for backend, kinds in other_backends.items():
        for klass in kinds:
            add(backend, klass)
    ids = opaque_ids(len(rows), seed)
    out = []
    for i, ((klass, level, backend, params, effects, expected), case) in enumerate(zip(rows, ids)):
        label = CaseLabel(case, klass, expected, level, backend, params, effects)
        oracle = klass not in OTHER_CLASSES
        out.append(PlannedCase(label, tuple(TRUTH_SEED_BASE + 10 * i + r for r in range(REPLICATES)),
                               tuple(ORACLE_SEED_BASE + 10 * i + r for r in range(ORACLE_SEEDS)) if oracle else ()))
    return sorted(out, key=lambda c: c.label.case)


def truth_spec(model: BenchmarkModel, label: CaseLabel) -> ShearCellSpec:
    """The spec that made a case: the model at the truth's parameters with its hidden effects on."""
    spec = point_spec(model.spec, label.params, 0)
    by_parameter = {e.parameters[0].name: e for e in model.effects_all()}
    by_parameter["rolling_friction"] = RollingFriction(off=model.spec.material.rolling_friction)
    for name, value in label.effects.items():
        spec = by_parameter[name].apply(spec, {name: value})
    return spec.validate()
