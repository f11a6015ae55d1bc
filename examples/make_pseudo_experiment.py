"""Make a pseudo-experiment: run a backend at known parameters with several seeds (the
"replicates") and write a points CSV whose header says exactly how it was made.

    python examples/make_pseudo_experiment.py --simulator numba_dem --preset quick \
        --set youngs_modulus=2e10 --set sliding_friction=0.35 --replicates 3 -o examples/data/pseudo.csv

Made data is never presented as measured: the header names the backend, its version, the spec
hash, the parameters, effects and seeds.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from calibrax import ShearCellSpec, get_manager


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--simulator", default="numba_dem")
    p.add_argument("--preset", default="quick", help="fidelity preset: paper | quick | tiny")
    p.add_argument("--procedure", default="paper", help="procedure preset: paper | astm_d7891")
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                   help="a material field (repeatable), e.g. youngs_modulus=2e10")
    p.add_argument("--wall-friction", type=float, default=0.0, help="an effect to switch on (lateral wall μ)")
    p.add_argument("--replicates", type=int, default=3)
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("-o", "--output", type=Path, required=True)
    args = p.parse_args(argv)
    material = {}
    for item in args.set:
        key, _, value = item.partition("=")
        material[key] = float(value)
    spec = ShearCellSpec.preset(args.preset, args.procedure, material=material,
                                geometry={"wall_friction": args.wall_friction}).validate()
    simulator = get_manager().create("simulator", args.simulator)
    rows, seeds = [], []
    for r in range(args.replicates):
        seed = args.seed + r
        seeds.append(seed)
        with tempfile.TemporaryDirectory() as work:
            result = simulator.simulate(spec.replace(numerics={"seed": seed}), Path(work))
        print(f"replicate {r + 1} (seed {seed}): peaks {result.peak_shear_stress.round(0).tolist()} Pa, "
              f"C = {result.yield_locus().cohesion:.0f} Pa, AIF = {result.yield_locus().aif_deg:.1f}°", file=sys.stderr)
        for k in range(len(result.peak_shear_stress)):
            rows.append(f"{result.target_normal_stress[k]:.6g},{result.peak_shear_stress[k]:.6g},{r + 1},"
                        f"{spec.procedure.preshear_stress:.6g},{result.preshear_shear_stress[k]:.6g}")
    header = [
        "# PSEUDO-EXPERIMENT, NOT MEASURED DATA.",
        f"# Made by {args.simulator} ({simulator.version()}) with the '{args.preset}' preset and the "
        f"'{args.procedure}' procedure, spec hash {spec.spec_hash()} (seed 0 variant).",
        "# Material: " + ", ".join(f"{k} = {v:g}" for k, v in sorted(vars(spec.material).items())),
        f"# Effects: lateral wall friction = {args.wall_friction:g}; size distribution = {spec.size_distribution.kind}.",
        f"# Replicates are seeds {seeds} of the same spec.",
        "normal_stress_pa,peak_shear_stress_pa,replicate,preshear_normal_stress_pa,preshear_shear_stress_pa",
    ]
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text("\n".join(header + rows) + "\n")
    print(f"wrote {args.output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
