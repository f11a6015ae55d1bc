"""What the FT4's density tests see in a simulated cell: the conditioned bulk density and the
compressibility ramp, per effect, over seeds, side by side in one run.

    .venv/bin/python benchmarks/density_tests.py --seeds 4 --workers 2            # tiny, numba_dem
    .venv/bin/python benchmarks/density_tests.py --preset quick --seeds 3 --effects none,cohesion
    .venv/bin/python benchmarks/density_tests.py --procedure ft4_3kpa --seeds 3 --effects none,cohesion

Each row runs the shear test with ``procedure.compressibility_stresses`` = 1, 2, 4, 6, 8, 10, 12,
15 kPa (those up to the preshear stress, and the preshear stress, with ``--procedure ft4_3kpa``: the FT4's
3 kPa test, where a powder's Bond number is five times that at 15 kPa) at the quickstart's material (E = 20 GPa, μs = 0.35) with one effect at the diagnosis
benchmark's medium magnitude (wall friction 0.25, σ of ln r 0.25, Bond number 0.6) or with the unlisted effect (rolling friction
0.15 or 0 against the model's 0.5), and prints per
effect the mean ± seed s.d. of the conditioned bulk density, the bulk density after the first
preshear, the compressibility at 15 kPa, the mean peak τ/σ, the angle of internal friction and the yield locus's cohesion C, and each one's shift from no effect in noise units of a
3-replicate mean (the no-effect seed s.d. / √3). Prints; writes nothing.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import math
import multiprocessing
import sys
import tempfile
from pathlib import Path

import numpy as np

RAMP = (1000.0, 2000.0, 4000.0, 6000.0, 8000.0, 10000.0, 12000.0, 15000.0)
EFFECTS = {
    "none": {},
    "wall_friction": {"geometry": {"wall_friction": 0.25}},
    "size_distribution": {"size_distribution": {"kind": "lognormal", "sigma_log": 0.25}},
    "cohesion": {"material": {"bond_number": 0.6}},
    # the diagnosis benchmark's unlisted effect (particle shape through rolling friction, the
    # model's μr being 0.5) at its old magnitude and at none at all
    "rolling_friction_0.15": {"material": {"rolling_friction": 0.15}},
    "rolling_friction_0": {"material": {"rolling_friction": 0.0}},
}
QUANTITIES = (("conditioned_bulk_density", "CBD", "kg/m³", ".0f"),
              ("bulk_density", "ρ after preshear", "kg/m³", ".0f"),
              ("compressibility", "CPS at the preshear σ", "%", ".2f"),
              ("peak_ratio", "mean peak τ/σ", "", ".3f"),
              ("aif", "AIF", "°", ".1f"),
              ("cohesion", "C", "Pa", ".0f"))


def ramp_up_to(preshear_stress: float) -> tuple[float, ...]:
    """The FT4's ramp cut at the preshear stress (a ramp must not exceed it), ending at it, Pa."""
    return tuple(s for s in RAMP if s < preshear_stress) + (preshear_stress,)


def run_one(preset: str, procedure: str, effect: str, seed: int) -> dict[str, float]:
    from calibrax import get_manager
    from calibrax.core.sheartest import ShearCellSpec

    changes = EFFECTS[effect]
    material = {"youngs_modulus": 2.0e10, "sliding_friction": 0.35, **changes.get("material", {})}
    spec = ShearCellSpec.preset(preset, procedure)
    spec = spec.replace(
        material=material, numerics={"seed": seed, "threads": 1},
        procedure={"compressibility_stresses": ramp_up_to(spec.procedure.preshear_stress)},
        **{k: v for k, v in changes.items() if k != "material"})
    with tempfile.TemporaryDirectory(prefix="calibrax-density-") as work:
        result = get_manager().create("simulator", "numba_dem").simulate(spec.validate(), Path(work))
    return {"conditioned_bulk_density": result.conditioned_bulk_density, "bulk_density": float(result.bulk_density[0]),
            "compressibility": float(result.compressibility[-1]),
            "peak_ratio": float(np.mean(result.peak_shear_stress / result.target_normal_stress)),
            "aif": float(result.yield_locus().aif_deg), "cohesion": float(result.yield_locus().cohesion),
            "wall_time": result.provenance.wall_time}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="tiny", help="fidelity preset (default tiny)")
    ap.add_argument("--procedure", default="paper", help="procedure preset: paper (default) | astm_d7891 | ft4_3kpa")
    ap.add_argument("--seeds", type=int, default=4, help="seeds per effect (default 4)")
    ap.add_argument("--effects", default=",".join(EFFECTS), help=f"comma-separated, from {list(EFFECTS)}")
    ap.add_argument("--workers", type=int, default=2, help="simulations at once (default 2)")
    args = ap.parse_args(argv)
    effects = [e.strip() for e in args.effects.split(",") if e.strip()]
    bad = [e for e in effects if e not in EFFECTS]
    if bad or "none" not in effects or args.seeds < 2:
        print(f"error: --effects must include none and come from {list(EFFECTS)} (got {bad or effects}); "
              "--seeds ≥ 2", file=sys.stderr)
        return 2
    jobs = [(e, 1 + s) for e in effects for s in range(args.seeds)]
    with cf.ProcessPoolExecutor(args.workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(run_one, args.preset, args.procedure, e, s): (e, s) for e, s in jobs}
        rows: dict[str, list[dict[str, float]]] = {e: [] for e in effects}
        for f in cf.as_completed(futures):
            e, s = futures[f]
            out = f.result()
            rows[e].append(out)
            print(f"  {e} seed {s}: " + ", ".join(f"{q} {out[q]:.4g}" for q, *_ in QUANTITIES)
                  + f" ({out['wall_time']:.0f} s)", flush=True)
    base = {q: np.array([r[q] for r in rows["none"]]) for q, *_ in QUANTITIES}
    print(f"\n{args.preset}, procedure {args.procedure}, numba_dem, E = 20 GPa, μs = 0.35, {args.seeds} seeds per effect; shift in noise units of "
          "a 3-replicate mean (no effect's seed s.d. / √3)\n")
    print("| effect | " + " | ".join(f"{name} [{unit}] | shift" for _, name, unit, _ in QUANTITIES) + " |")
    print("|---|" + "---|---|" * len(QUANTITIES))
    for e in effects:
        cells = []
        for q, _, _, fmt in QUANTITIES:
            v = np.array([r[q] for r in rows[e]])
            noise = float(np.std(base[q], ddof=1)) / math.sqrt(3)
            shift = (v.mean() - base[q].mean()) / noise if noise > 0 else math.nan
            cells += [f"{v.mean():{fmt}} ± {np.std(v, ddof=1):{fmt}}", "–" if e == "none" else f"{shift:+.1f}"]
        print(f"| {e} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
