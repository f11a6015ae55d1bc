"""A diagnosis across fidelities on the real numba_dem engine: the pseudo-experiment is made at the
target (a hidden lateral wall friction), the design runs at the cheap fidelity, and the gap is
measured and the recalibration confirmed at the target (docs/explanation/diagnosis.md, "Across
fidelities").

    .venv/bin/python benchmarks/diagnose_fidelities.py --workers 2 -o runs/diagnose-fidelities
    .venv/bin/python benchmarks/diagnose_fidelities.py --target converged --wall-friction 0.3 --workers 2 \
        --experiment examples/data/pseudo-numba-converged-wall03.yaml -o runs/dfc

(the second reads the bundled experiment made at ``converged`` with a wall friction of 0.3, three
replicates, 2.1 CPU-hours; without ``--experiment`` it makes its own into the output folder; with
``--stores benchmarks/data/dfc-converged-wall03`` it resumes the converged simulations a run
before kept there instead of repeating them)

It starts from a known calibrated point (the truth's E and μs, a plausible region around it, as
tests/integration/test_diagnose_numba_dem.py does at one fidelity), so what it measures is the
diagnosis, not a campaign. It prints the verdict, the wall friction's interval against the truth,
the held-out gap before and after, and the CPU per fidelity; rerun, it resumes from its stores
(the pseudo-experiment too, replicate by replicate).
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

TRUTH = {"youngs_modulus": 2.0e10, "sliding_friction": 0.35}
PLAUSIBLE = {"youngs_modulus": (1.0e10, 4.0e10), "sliding_friction": (0.25, 0.45)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cheap", default="tiny", help="the design's fidelity preset (default tiny)")
    parser.add_argument("--target", default="quick", help="the target fidelity preset (default quick)")
    parser.add_argument("--wall-friction", type=float, default=0.4, help="the hidden lateral wall μ (default 0.4)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--threads", type=int, default=1, help="numerics.threads of each simulation")
    parser.add_argument("--experiment", type=Path, default=None,
                        help="a pseudo-experiment made at the target with the hidden wall friction (its YAML), "
                             "instead of making one into the output folder (at converged: 2.1 CPU-hours)")
    parser.add_argument("--stores", type=Path, default=None,
                        help="a folder of an earlier run's diagnosis stores (*.h5, e.g. "
                             "benchmarks/data/dfc-converged-wall03): each is copied into the output's diagnosis "
                             "folder where that has none of its name, so the run resumes them")
    parser.add_argument("-o", "--output", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.experiment is not None and not args.experiment.is_file():
        parser.error(f"--experiment {args.experiment}: no such file (a pseudo-experiment's YAML)")
    if args.stores is not None and not sorted(args.stores.glob("*.h5")):
        parser.error(f"--stores {args.stores}: no diagnosis stores (*.h5) there")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s", stream=sys.stderr)

    from calibrax import ShearCellSpec
    from calibrax.core.data.experiment import load_experiment
    from calibrax.core.studies.pseudo_study import write_pseudo_experiment_resumably
    from calibrax.core.running.executor import LocalExecutor
    from calibrax.core.search.parameters import ParameterSpace
    from calibrax.diagnosis import Budget, Calibrated, diagnose, effects_by_name
    from calibrax.diagnosis.design import LEVEL_POINTS, TARGET_RUNS

    def spec(preset: str) -> ShearCellSpec:
        return ShearCellSpec.preset(preset, "paper", material=dict(TRUTH, rolling_friction=0.5),
                                    numerics={"threads": args.threads}).validate()

    out = args.output
    out.mkdir(parents=True, exist_ok=True)
    experiment = args.experiment or out / "walled.yaml"
    if not experiment.is_file():
        write_pseudo_experiment_resumably(spec(args.target).replace(geometry={"wall_friction": args.wall_friction}),
                                          "numba_dem", out / "walled", out / "walled-replicates.h5", replicates=3,
                                          workers=args.workers)
    space = ParameterSpace.from_config({"youngs_modulus": {"low": 5e9, "high": 5e10, "log": True},
                                        "sliding_friction": {"low": 0.1, "high": 0.9}})
    calibrated = Calibrated("numba_dem", spec(args.target), space, load_experiment(experiment), dict(TRUTH), PLAUSIBLE,
                            target=args.target, cheap=(args.cheap, spec(args.cheap)))
    # the one-fidelity DEM test's design (tests/integration/test_diagnose_numba_dem.py) at the cheap
    # level, TARGET_RUNS replicates and confirmations at the target
    budget = Budget(replicates=3, baseline=3, per_effect=5, confirm=TARGET_RUNS, target_replicates=TARGET_RUNS,
                    level_points=LEVEL_POINTS)
    if args.stores is not None:
        seed_stores(args.stores, out / "walled.diagnosis")
    d = diagnose(calibrated, effects_by_name(), out / "walled.diagnosis", LocalExecutor(args.workers), budget=budget)
    interval = d.recalibrated.get("effect_interval", {}).get("wall_friction")
    ranked = d.ranking.models[0]
    print(f"verdict: {d.verdict} ({d.reason})")
    print(f"design's first: {ranked.name} (p = {ranked.probability:.2f})")
    if interval:
        print(f"wall friction: {d.recalibrated['effect_values']['wall_friction']:.3f}, 95 % interval "
              f"{interval[0]:.3f} to {interval[1]:.3f}; truth {args.wall_friction}")
    print(f"held-out gap (RMS z): {d.gap_before:.2f} before, {d.gap_after:.2f} after")
    for name, row in d.simulations.get("by_fidelity", {}).items():
        print(f"{name}: {row['simulations']} simulations, {row['cpu_seconds'] / 3600:.2f} CPU-hours "
              f"({row['engine_seconds'] / 3600:.2f} h of engine wall time)")
    print(json.dumps(d.simulations))
    return 0


def seed_stores(source: Path, folder: Path) -> None:
    """Copy each store of ``source`` into ``folder`` where it has none of that name (a store there
    is the newer: it may hold more)."""
    import shutil

    folder.mkdir(parents=True, exist_ok=True)
    for store in sorted(source.glob("*.h5")):
        if not (folder / store.name).exists():
            shutil.copy2(store, folder / store.name)
            logging.info("diagnose_fidelities: resuming %s from %s", store.name, source)


if __name__ == "__main__":
    sys.exit(main())
