"""Write the DEM design that benchmarks/calibration.py fits its response surface to, as a CSV.

    .venv/bin/python benchmarks/design_data.py --store runs/design-quick.h5 \\
        --seed-cache runs/noise-quick-015 --set youngs_modulus=25e9 --set sliding_friction=0.5 \\
        -o benchmarks/data/design-quick.csv

Rows: one simulation each, with its point label, (E, μs), seed and the ``robust`` metric's features
(mean peak τ/σ over the shear steps, mean preshear τ/σ, bulk density) and the four peak τ (Pa).
``--store``: a campaign store (every finished simulation of every point); ``--seed-cache``: a
folder of benchmarks/seed_noise.py results at one point, whose parameters ``--set`` names.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

COLUMNS = ("point", "youngs_modulus", "sliding_friction", "seed", "peak_ratio", "preshear_ratio", "bulk_density",
           "tau_peak_1", "tau_peak_2", "tau_peak_3", "tau_peak_4")


def _row(label: str, params: dict[str, float], result) -> dict[str, object]:
    from calibrax.plugins.builtin.metrics import RobustMetric
    from calibrax.core.data.features import result_features

    f = RobustMetric._aggregate(result_features(result))
    row = {"point": label, "youngs_modulus": params["youngs_modulus"], "sliding_friction": params["sliding_friction"],
           "seed": result.provenance.seed, **{k: f[k] for k in ("peak_ratio", "preshear_ratio", "bulk_density")}}
    for i, tau in enumerate(result.peak_shear_stress[:4], 1):
        row[f"tau_peak_{i}"] = float(tau)
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--store", action="append", default=[], type=Path, help="a campaign store (repeatable)")
    ap.add_argument("--seed-cache", action="append", default=[], type=Path,
                    help="a benchmarks/seed_noise.py --cache folder (repeatable, with one --set list for all)")
    ap.add_argument("--set", action="append", default=[], help="NAME=VALUE of the seed caches' point")
    ap.add_argument("--note", default="", help="a line for the CSV's header saying how the data were made")
    ap.add_argument("-o", "--output", type=Path, required=True)
    args = ap.parse_args(argv)
    import h5py

    from calibrax.core.running.store import CampaignStore, read_result_group

    rows = []
    for path in args.store:
        store = CampaignStore(path)
        for p in store.points():
            for s in p.sims:
                if s.status == "done":
                    rows.append(_row(f"{path.stem}-p{p.id}", p.params(), store.result(p.id, s.index)))
    params = {k: float(v) for k, _, v in (s.partition("=") for s in args.set)}
    for folder in args.seed_cache:
        for f in sorted(folder.glob("seed_*.h5")):
            with h5py.File(f, "r") as h:
                rows.append(_row(folder.name, params, read_result_group(h["result"])))
    args.output.parent.mkdir(parents=True, exist_ok=True)
    with args.output.open("w", encoding="utf-8", newline="") as fh:
        fh.write("# DEM design for benchmarks/calibration.py, written by benchmarks/design_data.py\n")
        if args.note:
            fh.write(f"# {args.note}\n")
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in COLUMNS})
    print(f"written: {args.output} ({len(rows)} simulations)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
