"""DEM throughput in µs per particle-step on one shear-cell workload, for every installed engine:
numba_dem at 1 and 2 threads, LIGGGHTS on 1 MPI rank (the Debian ``liggghts`` binary) and YADE
(the Debian ``yade`` binary, 1 thread), in one run, with the ratios to LIGGGHTS.

Workloads (same particles, radius, material, time step and cylinder for every engine):
  * ``bed``: the chosen preset's particles poured and settled by numba_dem in the cylinder on the
    flat base, no head, under gravity; every engine starts from exactly these positions and
    velocities (LIGGGHTS through a data file, YADE through a JSON parameter file read by the fixed
    script ``dem_throughput_yade.py``), runs ``--warmup`` untimed steps (contact histories), then
    ``--steps`` timed steps. LIGGGHTS uses analytic walls (``wall/gran … primitive``) like
    numba_dem, YADE the facet cell of the yade backend.
  * ``preshear``: the consolidated bed under the bladed head, turning at the preset's rotation rate
    under the preshear stress, from numba_dem's consolidated state (particles, head height, angle
    and speed). LIGGGHTS runs it from the same state with the liggghts backend's own script
    (``calibrax_liggghts.script.write_inputs`` with a ``BenchStart``: the same STL head, base and
    ribs meshes, analytic cylinder, materials and head servo as its shear test), ``--warmup`` untimed
    steps, then ``--steps`` timed.

The engines are timed in ``--rounds`` interleaved rounds (each round times every engine once, so
that they share the machine's load); the table gives the median over rounds of the µs per
particle-step and the median of the per-round ratios to LIGGGHTS, and the load average.
Engines not installed are skipped (``--no-liggghts``, ``--no-yade`` skip them anyway).

``--device cuda`` adds numba_dem's CUDA path (:mod:`calibrax_numba_dem.cuda_engine`) on the same
states, rows ``numba_dem cuda …``: the kernels are compiled and the state copied up before the
clock starts, and the clock stops when the steps are done on the device (the head comes back).

Example: python benchmarks/dem_throughput.py --preset quick --steps 2000 --rounds 3
"""

from __future__ import annotations

import argparse
import copy
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
from calibrax.core.sheartest.procedure_stages import Consolidate, InsertBlades, Pour
from calibrax_numba_dem.engine import DEMSystem, numba_threads
from calibrax_numba_dem.layout import H_OMEGA, H_PHI, H_VZ, H_Z, P_USE_HEAD
from calibrax_numba_dem.procedure import RunLog, ShearTestDriver, new_logger

YADE_SCRIPT = Path(__file__).with_name("dem_throughput_yade.py")


# ----------------------------------------------------------------------------------- numba_dem
def prepare(spec: ShearCellSpec, preshear: bool) -> tuple[DEMSystem, DEMSystem | None]:
    """(settled bed without head, consolidated bed shearing under the head or None), numba_dem."""
    driver = ShearTestDriver(spec, RunLog(new_logger(os.path.join(tempfile.mkdtemp(), "bench.log"))))
    with numba_threads(1):
        driver.run_stage(Pour())
        bed = copy.deepcopy(driver.sys)
        if not preshear:
            return bed, None
        driver.run((InsertBlades(spec.procedure.preshear_stress), Consolidate(spec.procedure.preshear_stress)))
    driver.sys.head[H_OMEGA] = spec.procedure.rotation_rate
    driver.set_servo(spec.procedure.preshear_stress, 0.05)
    with numba_threads(1):
        driver.sys.advance(200)
    return bed, driver.sys


def time_numba(system: DEMSystem, steps: int, threads: int) -> float:
    """µs per particle-step of ``steps`` steps from a copy of ``system`` on ``threads`` threads."""
    with numba_threads(threads):
        s = copy.deepcopy(system)
        t0 = time.perf_counter()
        s.advance(steps)
        return (time.perf_counter() - t0) / (steps * s.n) * 1e6


def time_cuda(system: DEMSystem, steps: int) -> float:
    """µs per particle-step of ``steps`` steps of numba_dem's CUDA path from a copy of ``system``
    (compiled and copied to the device beforehand, untimed)."""
    from calibrax_numba_dem.cuda_engine import CudaDEMSystem

    gpu = CudaDEMSystem(None, None, 1.0, None, host=copy.deepcopy(system))
    gpu.advance(2)  # the first launch compiles the kernels
    t0 = time.perf_counter()
    gpu.advance(steps)  # returns once the head is back from the device: every step is done
    return (time.perf_counter() - t0) / (steps * gpu.n) * 1e6


# ----------------------------------------------------------------------------------- LIGGGHTS
def liggghts_inputs(spec: ShearCellSpec, bed: DEMSystem, workdir: Path, warmup: int, steps: int) -> None:
    """Write ``bed.data`` (the settled bed) and ``in.bench`` into ``workdir``. Atom types: 1
    particles, 2 lateral wall, 3 base; every number goes through calibrax_liggghts' ``num``."""
    from calibrax_liggghts.script import integer, num

    m, g = spec.material, spec.geometry
    rc = g.vessel_diameter / 2.0
    r_max = float(bed.rad.max())
    half = 1.1 * rc + 2.0 * r_max
    top = float(np.max(bed.x[:, 2])) + 6.0 * r_max
    lines = ["calibrax dem_throughput bed (generated)", "", f"{integer(bed.n)} atoms", "3 atom types", "",
             f"{num(-half)} {num(half)} xlo xhi", f"{num(-half)} {num(half)} ylo yhi",
             f"{num(-2.0 * r_max)} {num(top)} zlo zhi", "", "Atoms", ""]
    for i in range(bed.n):
        lines.append(f"{i + 1} 1 {num(2.0 * bed.rad[i])} {num(m.density)} "
                     f"{num(bed.x[i, 0])} {num(bed.x[i, 1])} {num(bed.x[i, 2])}")
    lines += ["", "Velocities", ""]
    for i in range(bed.n):
        lines.append(f"{i + 1} " + " ".join(num(c) for c in (*bed.v[i], *bed.w[i])))
    (workdir / "bed.data").write_text("\n".join(lines) + "\n", encoding="ascii")
    mu_b, mur_b = spec.effective_base_friction()
    mur_w = m.rolling_friction if g.wall_friction > 0 else 0.0
    mu = [[m.sliding_friction, g.wall_friction, mu_b], [g.wall_friction, 0, 0], [mu_b, 0, 0]]
    mur = [[m.rolling_friction, mur_w, mur_b], [mur_w, 0, 0], [mur_b, 0, 0]]
    model = "model hertz tangential history rolling_friction epsd2"
    script = [
        "atom_style granular", "atom_modify map array", "boundary f f f", "newton off",
        "communicate single vel yes", "units si", "hard_particles yes", "read_data bed.data",
        f"neighbor {num(0.3 * float(bed.rad.min()))} bin", "neigh_modify delay 0",
        f"fix m1 all property/global youngsModulus peratomtype {' '.join([num(m.youngs_modulus)] * 3)}",
        f"fix m2 all property/global poissonsRatio peratomtype {' '.join([num(m.poisson_ratio)] * 3)}",
        f"fix m3 all property/global coefficientRestitution peratomtypepair 3 {' '.join([num(m.restitution)] * 9)}",
        f"fix m4 all property/global coefficientFriction peratomtypepair 3 "
        f"{' '.join(num(c) for row in mu for c in row)}",
        f"fix m5 all property/global coefficientRollingFriction peratomtypepair 3 "
        f"{' '.join(num(c) for row in mur for c in row)}",
        f"pair_style gran {model}", "pair_coeff * *", f"timestep {num(spec.time_step)}",
        "fix gravi all gravity 9.81 vector 0.0 0.0 -1.0",
        f"fix cyl all wall/gran {model} primitive type 2 zcylinder {num(rc)} 0.0 0.0",
        f"fix base all wall/gran {model} primitive type 3 zplane 0.0",
        "fix integr all nve/sphere", "thermo 100000",
        f"run {integer(warmup)}", f"run {integer(steps)}"]
    (workdir / "in.bench").write_text("\n".join(script) + "\n", encoding="ascii")


def liggghts_preshear_inputs(spec: ShearCellSpec, sheared: DEMSystem, workdir: Path, warmup: int,
                             steps: int) -> str:
    """Write the preshear workload for LIGGGHTS into ``workdir`` with the liggghts backend's own
    script generation, from numba_dem's state ``sheared``; returns the script's file name."""
    from calibrax_liggghts.script import SCRIPT_NAME, BenchStart, write_inputs

    h = sheared.head
    write_inputs(spec, workdir, BenchStart(radii=sheared.rad, x=sheared.x, v=sheared.v, w=sheared.w,
                                           head_z=float(h[H_Z]), head_phi=float(h[H_PHI]),
                                           head_vz=float(h[H_VZ]), warmup=warmup, steps=steps))
    return SCRIPT_NAME


def time_liggghts(exe: str, spec: ShearCellSpec, bed: DEMSystem, warmup: int, steps: int,
                  preshear: bool = False) -> tuple[float, str]:
    """(µs per particle-step of LIGGGHTS (1 rank) on ``bed`` (the settled bed, or with ``preshear``
    the sheared state) from its loop time of the timed run, LIGGGHTS' version line)."""
    with tempfile.TemporaryDirectory() as tmp:
        if preshear:
            script = liggghts_preshear_inputs(spec, bed, Path(tmp), warmup, steps)
        else:
            liggghts_inputs(spec, bed, Path(tmp), warmup, steps)
            script = "in.bench"
        proc = subprocess.run([exe, "-in", script, "-echo", "none", "-log", "none"], cwd=tmp,
                              capture_output=True, text=True, errors="replace")
    if proc.returncode != 0:
        raise RuntimeError("LIGGGHTS failed:\n" + proc.stdout[-2000:] + proc.stderr[-2000:])
    loops = re.findall(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", proc.stdout)
    t, k, atoms = loops[-1]
    if int(atoms) != bed.n or int(k) != steps:
        raise RuntimeError(f"LIGGGHTS ran {k} steps with {atoms} atoms, expected {steps} with {bed.n}")
    version = next((line.strip() for line in proc.stdout.splitlines() if line.startswith("LIGGGHTS")), "LIGGGHTS")
    return float(t) / (steps * bed.n) * 1e6, version


# ----------------------------------------------------------------------------------- YADE
def yade_params(spec: ShearCellSpec, bed: DEMSystem, warmup: int, steps: int) -> dict:
    """The parameter file of ``dem_throughput_yade.py``: the yade backend's contact mapping and
    facet cell, and the settled bed (SI units)."""
    from calibrax_yade.contact import contact_params
    from calibrax_yade.geometry import base_mesh, vessel_mesh

    g = spec.geometry
    cp = contact_params(spec)
    rc = g.vessel_diameter / 2.0
    r_min = float(bed.rad.min())
    top = float(np.max(bed.x[:, 2])) + 6.0 * float(bed.rad.max())
    mu_b, _ = spec.effective_base_friction()

    def flat(a: np.ndarray) -> list[float]:
        return [float(c) for c in np.asarray(a, dtype=float).reshape(-1)]

    return {"young": cp.young, "poisson": cp.poisson, "facet_young": cp.facet_young,
            "facet_poisson": cp.facet_poisson, "restitution": cp.restitution,
            "shear_restitution": cp.shear_restitution, "krot": cp.krot, "eta": cp.eta,
            "density": spec.material.density, "friction": spec.material.sliding_friction,
            "wall_friction": g.wall_friction, "base_friction": mu_b, "gravity": 9.81, "dt": spec.time_step,
            "vessel_facets": flat(vessel_mesh(rc, top, r_min)), "base_facets": flat(base_mesh(rc, r_min)),
            "radii": flat(bed.rad), "positions": flat(bed.x), "velocities": flat(bed.v), "spins": flat(bed.w),
            "warmup_steps": warmup, "steps": steps, "repeats": 1}


def time_yade(exe: str, spec: ShearCellSpec, bed: DEMSystem, warmup: int, steps: int) -> tuple[float, str]:
    """(µs per particle-step of YADE on 1 thread on ``bed``, YADE's version)."""
    import json

    from calibrax_yade.runner import run_yade, write_params

    with tempfile.TemporaryDirectory() as tmp:
        wd = Path(tmp)
        params = write_params(wd / "params.json", yade_params(spec, bed, warmup, steps))
        run_yade(exe, YADE_SCRIPT, params, wd, threads=1, timeout=3600.0)
        out = json.loads((wd / "result.json").read_text())
    if out["particles"] != bed.n:
        raise RuntimeError(f"YADE ran {out['particles']} particles, expected {bed.n}")
    return min(out["seconds"]) / (steps * bed.n) * 1e6, "YADE " + str(out["yade_version"])


# ----------------------------------------------------------------------------------- main
def find_engines(args: argparse.Namespace) -> dict[str, str]:
    """Executables of the external engines to time: {"liggghts": path, "yade": path}."""
    found = {}
    if not args.no_liggghts:
        exe = shutil.which("liggghts")
        if exe:
            found["liggghts"] = exe
        elif args.liggghts:
            raise SystemExit("liggghts not found (apt-get install liggghts)")
    if not args.no_yade:
        exe = shutil.which(os.environ.get("CALIBRAX_YADE", "yade"))
        if exe:
            found["yade"] = exe
    return found


def load() -> str:
    """The 1, 5 and 15-minute load averages."""
    return " ".join(f"{a:.2f}" for a in os.getloadavg()) if hasattr(os, "getloadavg") else "?"


def report(rows: dict[str, list[float]]) -> None:
    """Print the medians over rounds and the median per-round ratio to LIGGGHTS on the same
    workload."""
    print(f"{'engine':30s} {'µs/particle-step':>17s} {'per round':>26s} {'/ LIGGGHTS':>11s}")
    for name, vals in rows.items():
        ratio = ""
        ref = rows.get("LIGGGHTS 1 rank " + name.rsplit(" ", 1)[-1])
        if ref and not name.startswith("LIGGGHTS"):
            ratio = f"{statistics.median(a / b for a, b in zip(vals, ref)):11.2f}"
        per = " ".join(f"{v:.3f}" for v in vals)
        print(f"{name:30s} {statistics.median(vals):17.3f} {per:>26s} {ratio}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="quick", choices=["tiny", "quick", "paper"])
    ap.add_argument("--steps", type=int, default=2000, help="timed steps per engine and round (default 2000)")
    ap.add_argument("--warmup", type=int, default=300, help="untimed steps before LIGGGHTS/YADE time (default 300)")
    ap.add_argument("--rounds", "--repeats", type=int, default=3, dest="rounds",
                    help="interleaved rounds, medians reported (default 3)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="numba thread counts (default 1 2)")
    ap.add_argument("--device", choices=["cpu", "cuda"], default="cpu",
                    help="cuda: time numba_dem's CUDA path too, on the same states (needs a GPU)")
    ap.add_argument("--liggghts", action="store_true", help="fail if LIGGGHTS is not installed")
    ap.add_argument("--no-liggghts", action="store_true", help="skip LIGGGHTS")
    ap.add_argument("--no-yade", action="store_true", help="skip YADE")
    ap.add_argument("--no-preshear", action="store_true", help="skip numba_dem's preshear workload")
    args = ap.parse_args()
    threads = [t for t in args.threads if t <= numba.config.NUMBA_NUM_THREADS]
    engines = find_engines(args)
    spec = ShearCellSpec.preset(args.preset)
    t0 = time.perf_counter()
    bed, sheared = prepare(spec, not args.no_preshear)
    bed.params[P_USE_HEAD] = 0.0
    with numba_threads(1):
        bed.advance(args.warmup)
    print(f"preset {args.preset}: {bed.n} particles, dt {spec.time_step:.3e} s, {args.steps} steps x {args.rounds} "
          f"rounds (beds prepared in {time.perf_counter() - t0:.0f} s); numba {numba.__version__}, "
          f"{numba.config.NUMBA_NUM_THREADS} cores seen, threading layer {numba.threading_layer()}; "
          f"engines: numba_dem{''.join(', ' + e for e in engines)}")
    print(f"load average before: {load()}")
    rows: dict[str, list[float]] = {}
    versions: dict[str, str] = {}
    for _ in range(args.rounds):
        for t in threads:
            rows.setdefault(f"numba_dem {t} thr bed", []).append(time_numba(bed, args.steps, t))
        if args.device == "cuda":
            rows.setdefault("numba_dem cuda bed", []).append(time_cuda(bed, args.steps))
        if "liggghts" in engines:
            us, versions["liggghts"] = time_liggghts(engines["liggghts"], spec, bed, args.warmup, args.steps)
            rows.setdefault("LIGGGHTS 1 rank bed", []).append(us)
        if "yade" in engines:
            us, versions["yade"] = time_yade(engines["yade"], spec, bed, args.warmup, args.steps)
            rows.setdefault("YADE 1 thr bed", []).append(us)
        if sheared is not None:
            for t in threads:
                rows.setdefault(f"numba_dem {t} thr preshear", []).append(time_numba(sheared, args.steps, t))
            if args.device == "cuda":
                rows.setdefault("numba_dem cuda preshear", []).append(time_cuda(sheared, args.steps))
            if "liggghts" in engines:
                us, versions["liggghts"] = time_liggghts(engines["liggghts"], spec, sheared, args.warmup,
                                                         args.steps, preshear=True)
                rows.setdefault("LIGGGHTS 1 rank preshear", []).append(us)
    print(f"load average after: {load()}" + "".join(f"; {v}" for v in versions.values()))
    busy = os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0
    if busy > 0.5:
        print(f"note: the machine was busy (load average {busy:.1f} on {os.cpu_count()} cores): timings are noisy, "
              "compare the per-round ratios; multi-thread timings are meaningless when the load fills the cores")
    report(rows)
    if len(threads) > 1:
        a, b = threads[0], threads[-1]
        for w in ("bed", "preshear"):
            one, many = rows.get(f"numba_dem {a} thr {w}"), rows.get(f"numba_dem {b} thr {w}")
            if one and many:
                sp = statistics.median(x / y for x, y in zip(one, many))
                print(f"numba_dem {w}: speed-up {b} vs {a} threads x{sp:.2f} (median of per-round ratios)")
    print("µs per particle-step = wall time / (steps x particles); medians over rounds.")


if __name__ == "__main__":
    main()
