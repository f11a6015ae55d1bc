"""A pseudo-experiment whose replicates are stored as each ends, so that a killed run resumes
without repeating one: what a replicate of the ``converged`` cell (42 CPU-minutes) needs.

The replicates run as a study (:func:`~calibrax.core.studies.study.run_study`) into ``store``; once
all are there the experiment is written as :func:`~calibrax.core.data.pseudo.write_pseudo_experiment`
writes it (the same seeds give the same files).
"""

from __future__ import annotations

from pathlib import Path

from calibrax.core.data.pseudo import EXPERIMENT_SEED_BASE, replicate_seeds, write_pseudo_results
from calibrax.core.registry import get_manager
from calibrax.core.running.executor import LocalExecutor
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.core.studies.study import StudyCase, run_study
from calibrax.errors import SimulationFailed


def write_pseudo_experiment_resumably(spec: ShearCellSpec, simulator_name: str, out: Path, store: Path,
                                      replicates: int = 3, first_seed: int = EXPERIMENT_SEED_BASE + 1000,
                                      cell_words: str = "", workers: int = 1) -> Path:
    """Run ``replicates`` seeds of ``spec`` into ``store`` (resuming it) and write ``out``.yaml
    and its CSVs; the arguments are :func:`~calibrax.core.data.pseudo.write_pseudo_experiment`'s,
    plus ``store``, an HDF5 file (its engines' folders go beside it, ``store`` without ``.h5`` +
    ``.runs``).

    Raises:
        SimulationFailed: a replicate failed (its reason named); nothing is written. The store
            keeps the failure as data, so a rerun stops the same way: delete the store, or give
            other seeds.
    """
    store = Path(store)
    seeds = replicate_seeds(first_seed, replicates)
    case = StudyCase("replicates", simulator_name, spec, tuple(seeds))
    [outcome] = run_study([case], store, LocalExecutor(workers), store.with_suffix(".runs"), "pseudo")
    if outcome.failures:
        raise SimulationFailed(f"{len(outcome.failures)} of {replicates} replicates of {out} failed "
                               f"({'; '.join(outcome.failures)}); nothing written. {store} keeps every replicate as it "
                               "ended: delete it to run them all again, or give another first seed")
    version = get_manager().create("simulator", simulator_name).version()
    return write_pseudo_results(spec, simulator_name, version, seeds, list(outcome.results), out, cell_words)
