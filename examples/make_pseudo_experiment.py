"""Make a pseudo-experiment: run a backend at known parameters with several seeds (the
"replicates") and write it in the experiment format — a header YAML, a points CSV with everything
an FT4 user can measure besides the peaks (σ measured at each peak, the preshears' steady σ and τ,
the bulk density at the preshear stress) and a curves CSV with every shear step's τ curve:

    python examples/make_pseudo_experiment.py --simulator numba_dem --preset tiny \
        --set youngs_modulus=2e10 --set sliding_friction=0.35 --replicates 3 -o examples/data/pseudo-numba-tiny

(``--store runs/exp.h5`` keeps each replicate as it ends, so that a killed run resumes;
``--effect wall_friction=0.2``, ``--effect sigma_log=0.3``, ``--effect bond_number=0.6`` or
``--effect cohesion_energy_density=2e7`` switches an effect on) writes ``pseudo-numba-tiny.yaml``, ``pseudo-numba-tiny-points.csv`` and ``pseudo-numba-tiny-curves.csv``.

Made data is never presented as measured: the header names the backend, its version, the cell
(preset, base), the spec hash, the parameters, effects and seeds. The replicates' seeds are drawn at
or above calibrax.core.data.pseudo.EXPERIMENT_SEED_BASE (2³⁰), where no campaign's simulation seed lies.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from calibrax import ShearCellSpec
from calibrax.core.data.pseudo import EXPERIMENT_SEED_BASE, write_pseudo_experiment

#: --effect NAME: the spec field it sets
EFFECTS = {"wall_friction": ("geometry", "wall_friction"), "sigma_log": ("size_distribution", "sigma_log"),
           "bond_number": ("material", "bond_number"),
           "cohesion_energy_density": ("material", "cohesion_energy_density")}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--simulator", default="numba_dem")
    p.add_argument("--preset", default="quick", help="fidelity preset: paper | converged | quick | tiny")
    p.add_argument("--procedure", default="paper", help="procedure preset: paper | astm_d7891")
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                   help="a material field (repeatable), e.g. youngs_modulus=2e10")
    p.add_argument("--wall-friction", type=float, default=0.0, help="lateral wall μ (same as --effect wall_friction=V)")
    p.add_argument("--effect", action="append", default=[], metavar="NAME=VALUE",
                   help=f"an effect to switch on (repeatable): {', '.join(EFFECTS)}")
    p.add_argument("--replicates", type=int, default=3)
    p.add_argument("--workers", type=int, default=1, help="replicates run at once")
    p.add_argument("--threads", type=int, default=None,
                   help="numerics.threads of each replicate (default: the preset's); converged on 2 cores: "
                        "--threads 2 --workers 1")
    p.add_argument("--seed", type=int, default=EXPERIMENT_SEED_BASE + 1000,
                   help=f"first replicate's seed, ≥ {EXPERIMENT_SEED_BASE} (campaigns never use those)")
    p.add_argument("--store", type=Path, default=None,
                   help="an HDF5 file that keeps each replicate as it ends, so that a killed run resumes "
                        "without repeating one (for the converged cell: 42 CPU-minutes a replicate)")
    p.add_argument("-o", "--output", type=Path, required=True, help="path and stem of the files to write")
    args = p.parse_args(argv)
    if args.seed < EXPERIMENT_SEED_BASE:
        p.error(f"--seed must be ≥ {EXPERIMENT_SEED_BASE}: below it a campaign's simulation could re-run a replicate")
    material = {}
    for item in args.set:
        key, _, value = item.partition("=")
        material[key] = float(value)
    changes: dict[str, dict] = {"material": material, "geometry": {"wall_friction": args.wall_friction}}
    if args.threads is not None:
        if args.threads < 1:
            p.error(f"--threads must be ≥ 1, got {args.threads}")
        changes["numerics"] = {"threads": args.threads}
    for item in args.effect:
        key, _, value = item.partition("=")
        if key not in EFFECTS:
            p.error(f"--effect {key!r}: allowed {sorted(EFFECTS)}")
        group, field = EFFECTS[key]
        changes.setdefault(group, {})[field] = float(value)
        if key == "sigma_log" and float(value) > 0:
            changes[group]["kind"] = "lognormal"
    spec = ShearCellSpec.preset(args.preset, args.procedure, material=changes.pop("material"))
    spec = spec.replace(**changes).validate()

    def progress(r: int, result) -> None:
        locus = result.yield_locus()
        print(f"replicate {r + 1} (seed {result.provenance.seed}): peaks {result.peak_shear_stress.round(0).tolist()} Pa, "
              f"C = {locus.cohesion:.0f} Pa, AIF = {locus.aif_deg:.1f}°, bulk density {result.bulk_density[0]:.0f} kg/m³",
              file=sys.stderr)

    words = f"the '{args.preset}' preset and the '{args.procedure}' procedure"
    if args.store is not None:
        from calibrax.core.studies.pseudo_study import write_pseudo_experiment_resumably

        logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s", stream=sys.stderr)
        path = write_pseudo_experiment_resumably(spec, args.simulator, args.output, args.store, args.replicates,
                                                 args.seed, words, args.workers)
    else:
        path = write_pseudo_experiment(spec, args.simulator, args.output, args.replicates, args.seed, words, progress,
                                       args.workers)
    print(f"wrote {path} and its points and curves", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
