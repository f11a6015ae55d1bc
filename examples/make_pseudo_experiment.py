"""Make a pseudo-experiment: run a backend at known parameters with several seeds (the
"replicates") and write it in the experiment format — a header YAML, a points CSV with everything
an FT4 user can measure besides the peaks (σ measured at each peak, the preshears' steady σ and τ,
the bulk density at the preshear stress) and a curves CSV with every shear step's τ curve:

    python examples/make_pseudo_experiment.py --simulator numba_dem --preset tiny \
        --set youngs_modulus=2e10 --set sliding_friction=0.35 --replicates 3 -o examples/data/pseudo-numba-tiny

writes ``pseudo-numba-tiny.yaml``, ``pseudo-numba-tiny-points.csv`` and ``pseudo-numba-tiny-curves.csv``.

Made data is never presented as measured: the header names the backend, its version, the cell
(preset, base), the spec hash, the parameters, effects and seeds. The replicates' seeds are drawn at
or above calibrax.core.campaign.EXPERIMENT_SEED_BASE (2³⁰), where no campaign's simulation seed lies.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from calibrax import ShearCellSpec, get_manager
from calibrax.core.campaign import EXPERIMENT_SEED_BASE


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--simulator", default="numba_dem")
    p.add_argument("--preset", default="quick", help="fidelity preset: paper | quick | tiny")
    p.add_argument("--procedure", default="paper", help="procedure preset: paper | astm_d7891")
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                   help="a material field (repeatable), e.g. youngs_modulus=2e10")
    p.add_argument("--wall-friction", type=float, default=0.0, help="an effect to switch on (lateral wall μ)")
    p.add_argument("--replicates", type=int, default=3)
    p.add_argument("--seed", type=int, default=EXPERIMENT_SEED_BASE + 1000,
                   help=f"first replicate's seed, ≥ {EXPERIMENT_SEED_BASE} (campaigns never use those)")
    p.add_argument("-o", "--output", type=Path, required=True, help="path and stem of the files to write")
    args = p.parse_args(argv)
    if args.seed < EXPERIMENT_SEED_BASE:
        p.error(f"--seed must be ≥ {EXPERIMENT_SEED_BASE}: below it a campaign's simulation could re-run a replicate")
    material = {}
    for item in args.set:
        key, _, value = item.partition("=")
        material[key] = float(value)
    spec = ShearCellSpec.preset(args.preset, args.procedure, material=material,
                                geometry={"wall_friction": args.wall_friction}).validate()
    simulator = get_manager().create("simulator", args.simulator)
    points, curves, seeds = [], [], []
    for r in range(args.replicates):
        seed = args.seed + r
        seeds.append(seed)
        with tempfile.TemporaryDirectory() as work:
            result = simulator.simulate(spec.replace(numerics={"seed": seed}), Path(work))
        locus = result.yield_locus()
        print(f"replicate {r + 1} (seed {seed}): peaks {result.peak_shear_stress.round(0).tolist()} Pa, "
              f"C = {locus.cohesion:.0f} Pa, AIF = {locus.aif_deg:.1f}°, bulk density {result.bulk_density[0]:.0f} "
              f"kg/m³, base slip {np.nanmax(result.base_slip):.2f}", file=sys.stderr)
        shear = [s for s in result.steps if s.kind == "shear"]
        for k, step in enumerate(shear):
            points.append(f"{result.target_normal_stress[k]:.6g},{result.peak_shear_stress[k]:.6g},{r + 1},"
                          f"{result.peak_normal_stress[k]:.6g},{result.preshear_normal_stress[k]:.6g},"
                          f"{result.preshear_shear_stress[k]:.6g},{result.bulk_density[0]:.6g}")
            for rot, tau in zip(step.rotation, step.shear_stress):
                curves.append(f"{r + 1},{step.target_stress:.6g},{rot:.6g},{tau:.6g}")
    g = spec.geometry
    base = f"{g.base_ribs} ribs {g.rib_height * 1e3:.2g} mm high" if g.base_ribs else "flat"
    provenance = [
        "PSEUDO-EXPERIMENT, NOT MEASURED DATA.",
        f"Made by {args.simulator} ({simulator.version()}) with the '{args.preset}' preset and the "
        f"'{args.procedure}' procedure (base: {base}), spec hash {spec.spec_hash()} (seed 0 variant).",
        "Material: " + ", ".join(f"{k} = {v:g}" for k, v in sorted(vars(spec.material).items())),
        f"Effects: lateral wall friction = {args.wall_friction:g}; size distribution = {spec.size_distribution.kind}.",
        f"Replicates are seeds {seeds} of the same spec.",
    ]
    out = args.output.with_suffix("") if args.output.suffix in (".yaml", ".csv") else args.output
    out.parent.mkdir(parents=True, exist_ok=True)
    comment = "".join(f"# {line}\n" for line in provenance)
    points_path = out.parent / f"{out.name}-points.csv"
    curves_path = out.parent / f"{out.name}-curves.csv"
    points_path.write_text(comment + "normal_stress_pa,peak_shear_stress_pa,replicate,measured_normal_stress_pa,"
                           "preshear_normal_stress_pa,preshear_shear_stress_pa,bulk_density_kg_m3\n"
                           + "\n".join(points) + "\n")
    curves_path.write_text(comment + "replicate,normal_stress_pa,rotation_rad,shear_stress_pa\n" + "\n".join(curves) + "\n")
    header = {"name": out.name, "source": " ".join(provenance), "points": points_path.name,
              "curves": curves_path.name, "preshear_stress_pa": float(spec.procedure.preshear_stress),
              "cell": {"preset": args.preset, "procedure": args.procedure, "base_ribs": g.base_ribs,
                       "rib_height": g.rib_height, "wall_friction": args.wall_friction},
              "material": {k: float(v) for k, v in sorted(vars(spec.material).items())}}
    (out.parent / f"{out.name}.yaml").write_text(comment + yaml.safe_dump(header, sort_keys=False, allow_unicode=True))
    print(f"wrote {out.parent / (out.name + '.yaml')} and its points and curves", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
