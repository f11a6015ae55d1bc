"""The diagnosis's blind benchmark, both levels, as the issue-20 note reports them.

    .venv/bin/python benchmarks/diagnosis.py                      # emulator level, 30 per class (minutes)
    .venv/bin/python benchmarks/diagnosis.py --level dem --workers 2   # DEM level, 3 per class (hours)
    .venv/bin/python benchmarks/diagnosis.py make-design --workers 2   # re-make the shipped design data

The first two are ``calibrax diagnose-benchmark`` with these defaults (it prints the scores table
and writes scores.md, scores.json, confusion.png). ``make-design`` runs the shared DEM design of
the shipped model (calibrax/diagnosis/benchmark/data/tiny.yaml) and the unlisted effect's block,
and writes their features to calibrax/diagnosis/benchmark/data/design-tiny.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import logging
import sys
from pathlib import Path


def make_design(workers: int, folder: Path, output: Path) -> int:
    from calibrax import __version__
    from calibrax.diagnosis.benchmark.design import run_design, shared_cases, unlisted_cases
    from calibrax.diagnosis.benchmark.emulated import export_design
    from calibrax.diagnosis.benchmark.model import BenchmarkModel
    from calibrax.core.registry import get_manager

    model = BenchmarkModel.load()
    executor = get_manager().create("executor", "local", workers=workers)
    rows = []
    try:
        for unlisted in (False, True):
            points = (unlisted_cases if unlisted else shared_cases)(model)[0]
            _, outcomes = run_design(model, folder, executor, unlisted=unlisted)
            rows += export_design(model, outcomes, points, "")["rows"]
    finally:
        executor.shutdown()
    simulator = get_manager().create("simulator", model.simulator)
    about = (f"Made {datetime.date.today()} by benchmarks/diagnosis.py make-design with calibrax {__version__} and "
             f"{simulator.version()}: the diagnosis design of {model.source.name} (its calibrated point's replicates, "
             f"baseline points and {model.budget.per_effect} points per candidate effect over its box) and a block of "
             f"rolling-friction points (the unlisted effect), one simulation per row, features as "
             f"calibrax.diagnosis.gap.diagnosis_features reads them.")
    output.write_text(json.dumps({"about": about, "model": model.source.name, "rows": rows}, indent=1))
    print(f"written: {output} ({len(rows)} simulations)")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", nargs="?", default="score", choices=["score", "make-design"])
    ap.add_argument("--level", default="emulator", choices=["emulator", "dem"])
    ap.add_argument("--per-class", type=int)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--output", type=Path)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname).1s %(message)s", datefmt="%H:%M:%S")
    if args.what == "make-design":
        from calibrax.diagnosis.benchmark.emulated import DEFAULT_DESIGN

        # the DEM level's own design folder: a later --level dem run finds the design finished
        return make_design(args.workers, Path("runs/diagnose-benchmark-dem/design"), args.output or DEFAULT_DESIGN)
    from calibrax.diagnosis.benchmark.command import run_benchmark

    return run_benchmark(level=args.level, per_class=args.per_class, seed=args.seed, workers=args.workers,
                         output=args.output)


if __name__ == "__main__":
    sys.exit(main())
