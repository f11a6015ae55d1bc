"""The DEM level: cases made by real simulations, written blind, each diagnosed with real
simulations, and the oracle's simulations to measure the shrinkage against.

Steps, each a resumable study (a killed benchmark repeats no finished simulation):

1. the shared design (:mod:`calibrax.diagnosis.benchmark.design`);
2. the truths: every case's replicates on its truth backend (``truths-<hash>.h5``), written as
   blinded experiment files with measurement noise (``cases/``) and a ``labels.yaml``;
3. the oracles: the diagnosing backend at each listed-effect case's true parameters with the
   true effect at its true magnitude (``oracles-<hash>.h5``);
4. every case diagnosed from its blinded file alone (``diagnoses/<case>/``, the shared design
   copied in, so only its confirmation runs).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Callable

import numpy as np

from calibrax.core.studies.study import StudyCase, run_study
from calibrax.diagnosis import gap as gaps
from calibrax.diagnosis.benchmark.cases import MeasurementNoise, cell_words, write_blinded, write_labels
from calibrax.diagnosis.benchmark.design import run_design, seed_case_folder
from calibrax.diagnosis.benchmark.model import BenchmarkModel
from calibrax.diagnosis.benchmark.plan import PlannedCase, truth_spec
from calibrax.diagnosis.benchmark.scores import Answer, answer_from_diagnosis
from calibrax.diagnosis.run import stage_progress, study_store

log = logging.getLogger("calibrax")


def _study(cases: list[StudyCase], folder: Path, kind: str, executor) -> list:
    store = study_store(folder, kind, cases)
    return run_study(cases, store, executor, folder / "runs" / store.stem, kind, stage_progress(kind), shutdown=False)


def run_truths(model: BenchmarkModel, plans: list[PlannedCase], folder: Path, executor) -> dict[str, list]:
    """Every case's replicates on its truth backend: {case id: results}."""
    # other backends' cases first: they are the slow ones, and a worker left idle at the end is wasted
    order = sorted(plans, key=lambda p: (p.label.truth_backend == model.simulator, p.label.case))
    cases = [StudyCase(p.label.case, p.label.truth_backend, truth_spec(model, p.label), p.seeds, dict(p.label.params))
             for p in order]
    return {c.case.label: c.good for c in _study(cases, folder, "truths", executor)}


def run_oracles(model: BenchmarkModel, plans: list[PlannedCase], folder: Path, executor) -> dict[str, list]:
    """The oracle's simulations of every listed-effect case: {case id: results}."""
    cases = [StudyCase(p.label.case, model.simulator, truth_spec(model, p.label), p.oracle_seeds, dict(p.label.params))
             for p in plans if p.oracle_seeds]
    return {c.case.label: c.good for c in _study(cases, folder, "oracles", executor)} if cases else {}


def write_cases(model: BenchmarkModel, plans: list[PlannedCase], truths: dict[str, list], folder: Path,
                noise: MeasurementNoise | None, seed: int) -> tuple[Path, Path]:
    """The blinded experiment files (``folder/cases/<id>.yaml``) and ``folder/labels.yaml``; a case
    whose replicates failed to fewer than two is left out (and logged)."""
    cases_dir = folder / "cases"
    kept = []
    for i, p in enumerate(plans):
        results = truths.get(p.label.case, [])
        if len(results) < 2:
            log.warning("diagnose-benchmark: case %s has %d good replicate(s) of %d; left out", p.label.case,
                        len(results), len(p.seeds))
            continue
        rng = np.random.default_rng([seed, i])
        write_blinded(results, cases_dir / p.label.case, cell_words(model.spec), noise, rng)
        kept.append(p.label)
    labels = folder / "labels.yaml"
    write_labels(kept, labels)
    return cases_dir, labels


def diagnose_cases(model: BenchmarkModel, case_files: list[Path], folder: Path, design_store: Path,
                   make_executor: Callable[[], object], oracles: dict[str, list] | None = None) -> list[Answer]:
    """Diagnose every case from its file alone; each gets its own folder with the shared design."""
    from calibrax.core.data.experiment import load_experiment
    from calibrax.diagnosis import diagnose

    answers = []
    for k, path in enumerate(case_files):
        case = path.stem
        experiment = load_experiment(path)
        out = folder / "diagnoses" / case
        seed_case_folder(design_store, out)
        log.info("diagnose-benchmark: case %d of %d (%s)", k + 1, len(case_files), case)
        result = diagnose(model.calibrated(experiment), model.effects(), out, make_executor(), backend=model.simulator,
                          budget=model.budget, seed=model.seed, asked=True)
        oracle_after = math.nan
        if oracles and oracles.get(case):
            peak_window = model.spec.procedure.peak_window
            sims = gaps.simulated(oracles[case], peak_window)
            rows = gaps.feature_gaps(sims, gaps.measured(experiment, peak_window), tuple(result.judge_on),
                                     result.seed_sd)
            oracle_after = gaps.gap_size(rows)
        answers.append(answer_from_diagnosis(case, result, oracle_after))
    return answers


def run_dem_level(model: BenchmarkModel, plans: list[PlannedCase], folder: Path, make_executor: Callable[[], object],
                  noise: MeasurementNoise | None = MeasurementNoise(), seed: int = 0) -> tuple[Path, list[Answer]]:
    """All four steps; returns the labels file and the answers."""
    executor = make_executor()
    try:
        design_store, _ = run_design(model, folder / "design", executor)
        truths = run_truths(model, plans, folder, executor)
        oracles = run_oracles(model, plans, folder, executor)
    finally:
        executor.shutdown()
    cases_dir, labels = write_cases(model, plans, truths, folder, noise, seed)
    files = sorted(cases_dir.glob("*.yaml"))
    return labels, diagnose_cases(model, files, folder, design_store, make_executor, oracles)
