"""The benchmark's DEM design: the simulations every case's diagnosis shares, and the extra block
(an unlisted effect's) that the emulator level's truth needs besides.

The diagnosis of a case starts from the benchmark model's calibrated point and box, so its design
(:meth:`BenchmarkModel.design`) is the same for every case: it runs once into a study store whose
name :func:`calibrax.diagnosis.run.study_store` derives from its simulations, and a copy of that
store in a case's folder is found finished by :func:`calibrax.diagnosis.diagnose`.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from calibrax.core.studies.study import StudyCase, run_study
from calibrax.diagnosis.benchmark.cases import RollingFriction, apply_mismatch, mismatch_backend
from calibrax.diagnosis.benchmark.model import BenchmarkModel
from calibrax.diagnosis.design import Budget, DesignPoint, design_points
from calibrax.diagnosis.run import design_case, stage_progress, study_store

#: simulations of the unlisted block (rolling friction over its range, calibrated parameters over the box)
UNLISTED_POINTS = 10
#: the unlisted block's design seed offset from the model's (its own Sobol points and simulation seeds)
UNLISTED_SEED_OFFSET = 50


def shared_cases(model: BenchmarkModel) -> tuple[list[DesignPoint], list[StudyCase]]:
    """The diagnosis design's points and the study cases that run them (what diagnose() runs)."""
    calibrated = model.calibrated(None)
    points = model.design()
    by_name = {e.name: e for e in model.effects()}
    return points, [design_case(calibrated, model.simulator, p, by_name) for p in points]


def unlisted_cases(model: BenchmarkModel) -> tuple[list[DesignPoint], list[StudyCase]]:
    """The rolling-friction block (the emulator level's unlisted effect)."""
    effect = RollingFriction(off=model.spec.material.rolling_friction)
    points = [p for p in design_points(model.box(), [effect], Budget(0, 0, UNLISTED_POINTS, 0),
                                       model.seed + UNLISTED_SEED_OFFSET) if p.seeds]
    calibrated = model.calibrated(None)
    return points, [design_case(calibrated, model.simulator, p, {effect.name: effect}) for p in points]


#: the shared design's first points (its calibrated point's replicates and this many baseline
#: points, with their seeds) that a mismatch block runs again with the mismatched procedure
MISMATCH_BASELINE = 4


def mismatch_cases(model: BenchmarkModel, kind: str) -> tuple[list[DesignPoint], list[StudyCase]]:
    """A mismatch's block (:data:`~calibrax.diagnosis.benchmark.cases.MISMATCHES`): the
    shared design's calibrated point and first baseline points with the same seeds, the same poured
    beds, made with the mismatched procedure, so that each simulation pairs with one of the design's
    and the mismatch's offset is measured free of most seed noise."""
    budget = Budget(model.budget.replicates, min(MISMATCH_BASELINE, model.budget.baseline), 0, 0)
    points = [p for p in design_points(model.box(), [], budget, model.seed) if p.seeds]
    calibrated = model.calibrated(None)
    cases = []
    for p in points:
        case = design_case(calibrated, model.simulator, p, {})
        cases.append(StudyCase(f"{kind}: {case.label}", mismatch_backend(kind, case.backend),
                               apply_mismatch(case.spec, kind).validate(), case.seeds, case.coords))
    return points, cases


def run_design(model: BenchmarkModel, folder: Path, executor, unlisted: bool = False,
               mismatch: str = "") -> tuple[Path, list]:
    """Run (or resume) the shared design, the unlisted block or a mismatch's block into
    ``folder``; returns the store and the outcomes."""
    if mismatch:
        points, cases = mismatch_cases(model, mismatch)
    else:
        points, cases = unlisted_cases(model) if unlisted else shared_cases(model)
    kind = f"mismatch-{mismatch}" if mismatch else "unlisted" if unlisted else "design"
    folder.mkdir(parents=True, exist_ok=True)
    store = study_store(folder, kind, cases)
    outcomes = run_study(cases, store, executor, folder / "runs" / store.stem, "diagnose", stage_progress(kind),
                         shutdown=False)
    return store, outcomes


def seed_case_folder(design_store: Path, case_out: Path) -> None:
    """Give a case's diagnosis folder a copy of the finished shared design store."""
    case_out.mkdir(parents=True, exist_ok=True)
    target = case_out / design_store.name
    if not target.exists():
        shutil.copy2(design_store, target)
