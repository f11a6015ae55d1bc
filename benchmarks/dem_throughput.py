"""numba_dem throughput in µs per particle-step on the shear cell, at 1 and 2 threads, and
optionally against LIGGGHTS (the Debian ``liggghts`` binary, 1 MPI rank).

Workloads (same particle count, radius, material and cylinder for both engines):
  * ``preshear``: the consolidated bed of the chosen preset under the bladed head, turning at the
    preset's rotation rate under the preshear stress (numba_dem only: the analytic head has no
    LIGGGHTS twin without meshes);
  * ``bed``: the same particles poured and settled in the cylinder under gravity, no head: the
    like-for-like workload timed on both engines.
Each timing is the median of ``--repeats`` runs of ``--steps`` steps from the same state.

Example: python benchmarks/dem_throughput.py --preset quick --steps 2000 --repeats 3 --liggghts
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import re
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from calibrax.core.sheartest import ShearCellSpec
from calibrax_numba_dem.engine import numba_threads
from calibrax_numba_dem.layout import H_OMEGA, P_USE_HEAD
from calibrax_numba_dem.procedure import RunLog, ShearTestDriver, new_logger


def time_numba(system, steps: int, repeats: int, threads: int) -> float:
    """Median µs per particle-step of ``steps`` steps from a copy of ``system``."""
    out = []
    with numba_threads(threads):
        warm = copy.deepcopy(system)
        warm.advance(20)  # loads/compiles kernels outside the timing
        for _ in range(repeats):
            s = copy.deepcopy(system)
            t0 = time.perf_counter()
            s.advance(steps)
            out.append((time.perf_counter() - t0) / (steps * s.n) * 1e6)
    return statistics.median(out)


LIGGGHTS_SCRIPT = """# calibrax dem_throughput: settled bed in the cylinder, Table 1 material
atom_style granular
atom_modify map array
boundary f f f
newton off
communicate single vel yes
units si
hard_particles yes
region domain block {lo} {hi} {lo} {hi} 0.0 {top} units box
create_box 1 domain
neighbor {skin} bin
neigh_modify delay 0
fix m1 all property/global youngsModulus peratomtype {E}
fix m2 all property/global poissonsRatio peratomtype {nu}
fix m3 all property/global coefficientRestitution peratomtypepair 1 {e}
fix m4 all property/global coefficientFriction peratomtypepair 1 {mu}
fix m5 all property/global coefficientRollingFriction peratomtypepair 1 {mur}
pair_style gran model hertz tangential history rolling_friction epsd2
pair_coeff * *
timestep {dt}
fix gravi all gravity 9.81 vector 0.0 0.0 -1.0
fix base all wall/gran model hertz tangential history rolling_friction epsd2 primitive type 1 zplane 0.0
fix cyl all wall/gran model hertz tangential history rolling_friction epsd2 primitive type 1 zcylinder {rc} 0.0 0.0
fix pts all particletemplate/sphere 15485863 atom_type 1 density constant {rho} radius constant {r}
fix pdd all particledistribution/discrete 32452843 1 pts 1.0
region ins cylinder z 0.0 0.0 {rins} {r} {top_ins} units box
fix ins all insert/pack seed 49979693 distributiontemplate pdd insert_every once overlapcheck yes all_in yes particles_in_region {n} region ins
fix integr all nve/sphere
thermo 10000
run 1
unfix ins
run {settle}
"""


def time_liggghts(spec: ShearCellSpec, n: int, steps: int, repeats: int, settle_steps: int) -> float:
    """Median µs per particle-step of LIGGGHTS (1 rank) on the settled bed."""
    exe = shutil.which("liggghts")
    if exe is None:
        raise SystemExit("liggghts not found (apt-get install liggghts)")
    m, r = spec.material, spec.radius
    rc = spec.geometry.vessel_diameter / 2
    top = 4.0 * spec.geometry.fill_height
    script = LIGGGHTS_SCRIPT.format(lo=-rc * 1.01, hi=rc * 1.01, top=top, skin=0.3 * r, E=m.youngs_modulus,
                                    nu=m.poisson_ratio, e=m.restitution, mu=m.sliding_friction,
                                    mur=m.rolling_friction, dt=spec.time_step, rc=rc, rho=m.density, r=r,
                                    rins=rc - 1.01 * r, top_ins=3.2 * spec.geometry.fill_height, n=n, settle=settle_steps)
    script += "".join(f"run {steps}\n" for _ in range(repeats))
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "in.bench").write_text(script)
        proc = subprocess.run([exe, "-in", "in.bench", "-echo", "none"], cwd=tmp, capture_output=True, text=True,
                              errors="replace")
        if proc.returncode != 0:
            raise SystemExit("LIGGGHTS failed:\n" + proc.stdout[-2000:] + proc.stderr[-2000:])
        loops = re.findall(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", proc.stdout)
    timed = [float(t) / (int(k) * int(a)) * 1e6 for t, k, a in loops if int(k) == steps]
    atoms = int(loops[-1][2])
    if atoms != n:
        print(f"  (LIGGGHTS inserted {atoms} of {n} particles)")
    return statistics.median(timed[-repeats:])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="quick", choices=["tiny", "quick", "paper"])
    ap.add_argument("--steps", type=int, default=2000, help="steps per timing (default 2000)")
    ap.add_argument("--repeats", type=int, default=3, help="timings per case, median reported (default 3)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="numba thread counts (default 1 2)")
    ap.add_argument("--liggghts", action="store_true", help="also time LIGGGHTS on the settled bed")
    ap.add_argument("--settle-steps", type=int, default=150000, help="LIGGGHTS settling steps before timing")
    args = ap.parse_args()
    threads = [t for t in args.threads if t <= numba.config.NUMBA_NUM_THREADS]
    spec = ShearCellSpec.preset(args.preset)
    tmp = tempfile.mkdtemp()
    driver = ShearTestDriver(spec, RunLog(new_logger(os.path.join(tmp, "bench.log"))))
    t0 = time.perf_counter()
    with numba_threads(1):
        driver.pour()
        bed = copy.deepcopy(driver.sys)
        driver.consolidate()
    driver.sys.head[H_OMEGA] = spec.procedure.rotation_rate
    driver._set_servo(spec.procedure.preshear_stress, 0.05)
    with numba_threads(1):
        driver.sys.advance(200)
    sheared = driver.sys
    bed.params[P_USE_HEAD] = 0.0
    print(f"preset {args.preset}: {sheared.n} particles, dt {spec.time_step:.3e} s, {args.steps} steps x "
          f"{args.repeats} repeats (bed prepared in {time.perf_counter() - t0:.0f} s); "
          f"cores seen by numba: {numba.config.NUMBA_NUM_THREADS}, layer {numba.threading_layer()}")
    rows = {}
    for name, system in (("preshear", sheared), ("bed", bed)):
        rows[name] = {t: time_numba(system, args.steps, args.repeats, t) for t in threads}
    print(f"{'workload':10s} " + " ".join(f"{f'numba {t} thr':>14s}" for t in threads)
          + (f" {'ratio 1/' + str(threads[-1]):>10s}" if len(threads) > 1 else ""))
    for name, r in rows.items():
        line = f"{name:10s} " + " ".join(f"{r[t]:11.3f} µs" for t in threads)
        if len(threads) > 1:
            line += f" {r[threads[0]] / r[threads[-1]]:10.2f}"
        print(line)
    if args.liggghts:
        lig = time_liggghts(spec, bed.n, args.steps, args.repeats, args.settle_steps)
        nb = rows["bed"][threads[0]]
        print(f"bed        LIGGGHTS 1 rank {lig:.3f} µs; numba_dem {threads[0]} thread {nb:.3f} µs; "
              f"numba_dem / LIGGGHTS = {nb / lig:.2f}")
    print("µs per particle-step = wall time / (steps x particles); medians.")


if __name__ == "__main__":
    main()
