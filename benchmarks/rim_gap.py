"""The gap between the shear head's rim and the vessel wall, in particle diameters, against a
frictional wall: one numba_dem test of the ``quick`` cell per call, its rim gap and wall friction
set, and what it read (peak and preshear τ, bulk density, C).

``tiny`` and ``quick`` set the head's radius to 0.48 of the vessel's diameter, so the gap is
0.02 D: 0.18 d and 0.24 d. ``paper`` and ``converged`` did too until 2026-12-07 (0.68 d and 0.92 d);
they now state 0.24 d (``rim_gap_d``). Where it is
between one particle radius and one diameter, a particle's centre passes the rim but the particle
does not fit: it can wedge between a blade's outer edge and the wall, and a frictional wall holds
the wedge (docs/explanation/sector.md, "A frictional wall and the rim gap"):

    .venv/bin/python benchmarks/rim_gap.py --gap 0.92 --wall-friction 0.3
    .venv/bin/python benchmarks/rim_gap.py --gap 0.92 --wall-friction 0
    .venv/bin/python benchmarks/rim_gap.py --wall-friction 0.3          # the preset's own gap
    .venv/bin/python benchmarks/rim_gap.py --preset converged --gap 0.24 --wall-friction 0.3  # ~42 CPU-min

Material: E 20 GPa, μs 0.35, μr 0.5 (the pseudo-experiments' truth); seed 7; one thread.
About 4 minutes a test (223 and 240 s with the machine to itself, 2026-12-07).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--gap", type=float, default=None,
                   help="the rim gap in particle diameters (default: the preset's)")
    p.add_argument("--wall-friction", type=float, required=True, help="geometry.wall_friction")
    p.add_argument("--preset", default="quick", help="a fidelity preset (default quick)")
    p.add_argument("--seed", type=int, default=7)
    args = p.parse_args(argv)

    from calibrax import ShearCellSpec, get_manager

    base = ShearCellSpec.preset(args.preset)
    d = 2.0 * base.radius
    vessel_radius = base.geometry.vessel_diameter / 2.0
    geometry: dict[str, float] = {"wall_friction": args.wall_friction}
    if args.gap is not None:
        geometry["head_radius"] = vessel_radius - args.gap * d
    spec = base.replace(geometry=geometry,
                        material={"youngs_modulus": 2e10, "sliding_friction": 0.35, "rolling_friction": 0.5},
                        numerics={"seed": args.seed, "threads": 1}).validate()
    gap_d = (vessel_radius - spec.geometry.head_radius) / d
    start = time.time()
    with tempfile.TemporaryDirectory() as work:
        result = get_manager().create("simulator", "numba_dem").simulate(spec, Path(work))
    locus = result.yield_locus()
    print(json.dumps({
        "preset": args.preset, "rim_gap_d": round(gap_d, 3), "wall_friction": args.wall_friction,
        "wall_s": round(time.time() - start),
        "peak_tau_kPa": [round(v / 1e3, 2) for v in result.peak_shear_stress],
        "shear_sigma_kPa": [round(v / 1e3, 2) for v in result.target_normal_stress],
        "preshear_tau_kPa": [round(v / 1e3, 2) for v in result.preshear_shear_stress],
        "bulk_density_kg_m3": [round(v) for v in result.bulk_density],
        "C_kPa": round(locus.cohesion / 1e3, 2), "AIF_deg": round(locus.aif_deg, 1),
        "warnings": list(result.warnings)}, ensure_ascii=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
