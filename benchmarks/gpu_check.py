"""numba_dem's CUDA path on a real GPU, in one run of under 8 minutes: what issue 52 asks to measure.

1. The CUDA path against the CPU path on the GPU itself: a quarter sector of ``tiny``, sheared, 200
   steps on both; the largest differences (round-off expected: the paths add the head's load in
   different orders).
2. Throughput, µs per particle-step, ``quick``'s poured bed and its preshear, on the CPU path at
   every core and on the CUDA path (benchmarks/dem_throughput.py's states and clocks), with the
   ratio; then beds of 16 particles per diameter and (in part 4) of the full ``converged`` cell
   poured by the CUDA path itself, timed on both paths.
3. One whole ``quick`` test per seed on both paths: its three features (C, AIF, the bulk density)
   side by side (equal within seed noise: the paths round differently, and a granular bed
   amplifies round-off), and each path's wall time.
4. The full ``converged`` cell (no sector, ≈ 31k particles), one whole test on the CUDA path in
   what is left of ``--budget-s``: its wall time and features, or, where it does not finish, how
   far it got and where the time went (its log's stage times).

Run it where a GPU is, without the simulator::

    NUMBA_ENABLE_CUDASIM=0 python benchmarks/gpu_check.py --out $OUT

Everything is printed and written to ``OUT/gpu_check.txt``, with the date and the GPU.
"""

from __future__ import annotations

import argparse
import copy
import datetime
import json
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

LINES: list[str] = []


def say(line: str) -> None:
    """Print ``line`` and keep it for the report file."""
    print(line, flush=True)
    LINES.append(line)


def compare_paths(steps: int) -> None:
    """Part 1: the sheared tiny sector on both paths, ``steps`` steps."""
    import numpy as np

    from calibrax.core.sheartest import ShearCellSpec
    from calibrax.core.sheartest.engine_control import RunLog
    from calibrax.core.sheartest.procedure_stages import Consolidate, InsertBlades, Pour
    from calibrax_numba_dem.cuda_engine import CudaDEMSystem
    from calibrax_numba_dem.layout import H_OMEGA
    from calibrax_numba_dem.procedure import ShearTestDriver

    spec = ShearCellSpec.preset("tiny").replace(geometry={"sector": 4})
    driver = ShearTestDriver(spec, RunLog(logging.getLogger("gpu_check")))
    driver.run_stage(Pour())
    driver.run((InsertBlades(spec.procedure.preshear_stress), Consolidate(spec.procedure.preshear_stress)))
    driver.set_servo(spec.procedure.preshear_stress, 0.05)
    driver.sys.head[H_OMEGA] = 10.0 * spec.procedure.rotation_rate
    cpu = copy.deepcopy(driver.sys)
    gpu = CudaDEMSystem(None, None, 1.0, None, host=copy.deepcopy(driver.sys))
    cpu.advance(steps)
    gpu.advance(steps)
    worst = {name: float(np.abs(getattr(gpu, name) - getattr(cpu, name)).max() / max(np.abs(getattr(cpu, name)).max(),
                                                                                    1e-30))
             for name in ("x", "v", "w", "f")}
    say(f"1. CUDA vs CPU path, tiny quarter sector sheared, {cpu.n} particles, {steps} steps, "
        f"{gpu.list_builds - driver.sys.list_builds} list builds: largest difference / largest value "
        + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))


def throughput(preset: str, steps: int, rounds: int) -> None:
    """Part 2: µs per particle-step, CPU path at every core and CUDA path, on the same states."""
    import statistics

    import numba

    from calibrax.core.sheartest import ShearCellSpec
    from calibrax_numba_dem.layout import P_USE_HEAD
    from dem_throughput import prepare, time_cuda, time_numba

    spec = ShearCellSpec.preset(preset)
    cores = numba.config.NUMBA_NUM_THREADS
    t0 = time.perf_counter()
    bed, sheared = prepare(spec, True)
    bed.params[P_USE_HEAD] = 0.0
    say(f"2. throughput, {preset}: {bed.n} particles (prepared in {time.perf_counter() - t0:.0f} s), {steps} steps "
        f"x {rounds} rounds, µs per particle-step (median):")
    for name, state in (("bed", bed), ("preshear", sheared)):
        cpu = [time_numba(state, steps, cores) for _ in range(rounds)]
        gpu = [time_cuda(state, steps) for _ in range(rounds)]
        say(f"   {name:9s} CPU {cores} threads {statistics.median(cpu):.4f}   CUDA {statistics.median(gpu):.4f}   "
            f"CPU/CUDA x{statistics.median(a / b for a, b in zip(cpu, gpu)):.1f}")


def poured_throughput(label: str, preset: str, geometry: dict, steps: int, timeout: float,
                      particles_per_diameter: float | None = None) -> None:
    """Part 2b: the bed of ``preset`` (``geometry`` overrides; at ``particles_per_diameter`` when
    given, scaled as ``calibrax converge`` scales it) poured by the CUDA path, then
    ``steps`` steps of it timed on the CUDA path and on the CPU path at every core, in a fresh
    process given ``timeout`` s."""
    code = f"""
import copy, json, logging, time, numba
from calibrax.core.sheartest import ShearCellSpec
from calibrax.core.sheartest.engine_control import RunLog
from calibrax.core.studies.convergence import with_particles_per_diameter
from calibrax.core.sheartest.procedure_stages import Pour
from calibrax_numba_dem.engine import numba_threads
from calibrax_numba_dem.layout import P_USE_HEAD
from calibrax_numba_dem.procedure import ShearTestDriver
spec = ShearCellSpec.preset({preset!r}).replace(numerics={{"device": "cuda"}}, geometry={geometry!r})
ppd = {particles_per_diameter!r}
if ppd is not None:
    spec = with_particles_per_diameter(spec, ppd)
driver = ShearTestDriver(spec, RunLog(logging.getLogger("gpu_check")))
t0 = time.perf_counter()
driver.run_stage(Pour())
pour = time.perf_counter() - t0
gpu = driver.sys
gpu.params[P_USE_HEAD] = 0.0
cpu = copy.deepcopy(gpu.pull())
gpu.advance(10)
t0 = time.perf_counter(); gpu.advance({steps}); t_gpu = time.perf_counter() - t0
with numba_threads(numba.config.NUMBA_NUM_THREADS):
    cpu.advance(10)
    t0 = time.perf_counter(); cpu.advance({steps}); t_cpu = time.perf_counter() - t0
print(json.dumps({{"n": gpu.n, "pour": pour, "gpu": t_gpu / ({steps} * gpu.n) * 1e6, "cpu": t_cpu / ({steps} * gpu.n) * 1e6}}))
"""
    try:
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        say(f"   {label}: did not finish in {timeout:.0f} s (pour and timing)")
        return
    if proc.returncode != 0:
        say(f"   {label}: failed: {proc.stderr[-800:]}")
        return
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    say(f"   {label}: {r['n']} particles poured on the GPU in {r['pour']:.0f} s; bed µs per particle-step: CPU "
        f"{r['cpu']:.4f}, CUDA {r['gpu']:.4f}, CPU/CUDA x{r['cpu'] / r['gpu']:.1f}")


def whole_test(preset: str, device: str, seed: int, threads: int, timeout: float, **geometry) -> dict:
    """One whole test in a fresh process (``timeout`` s): features, wall time, or the log's tail."""
    code = f"""
import json, sys
from pathlib import Path
from calibrax.core.sheartest import ShearCellSpec
from calibrax_numba_dem import NumbaDEMSimulator
spec = ShearCellSpec.preset({preset!r}).replace(numerics={{"device": {device!r}, "seed": {seed}, "threads": {threads}}},
                                               geometry={geometry!r})
r = NumbaDEMSimulator().simulate(spec, Path(sys.argv[1]))
locus = r.yield_locus()
print(json.dumps({{"C": locus.cohesion, "AIF": locus.aif_deg, "rho": float(sum(r.bulk_density) / len(r.bulk_density)),
                  "wall": r.provenance.wall_time, "n": r.provenance.particle_count,
                  "stage_cpu": r.provenance.extra.get("stage_cpu")}}))
"""
    work = tempfile.mkdtemp(prefix=f"gpu_check_{device}_")
    try:
        proc = subprocess.run([sys.executable, "-c", code, work], capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        log = Path(work, "numba_dem.log")
        tail = log.read_text(errors="replace").splitlines()[-12:] if log.exists() else []
        return {"timeout": timeout, "log": tail}
    if proc.returncode != 0:
        return {"error": proc.stderr[-1500:]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=".", help="folder of gpu_check.txt (default: here)")
    ap.add_argument("--budget-s", type=float, default=420.0, help="seconds for the whole check (default 420)")
    ap.add_argument("--steps", type=int, default=2000, help="timed steps of the throughput part (default 2000)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[11], help="seeds of part 3 (default 11)")
    args = ap.parse_args()
    start = time.perf_counter()
    from numba import cuda

    import numba

    if numba.config.ENABLE_CUDASIM or not cuda.is_available():
        print("gpu_check needs a CUDA GPU and NUMBA_ENABLE_CUDASIM=0", file=sys.stderr)
        return 2
    device = cuda.get_current_device()
    cores = numba.config.NUMBA_NUM_THREADS
    say(f"gpu_check {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC: {device.name.decode() if isinstance(device.name, bytes) else device.name}, "
        f"compute capability {device.compute_capability}; {cores} CPU threads; numba {numba.__version__}")
    steps = [("1", lambda: compare_paths(200)), ("2", lambda: throughput("quick", args.steps, 3))]
    for label, part in steps:
        t0 = time.perf_counter()
        try:
            part()
        except Exception as exc:  # noqa: BLE001 — report and go on to the next part
            say(f"{label}. failed: {exc!r}")
        say(f"   ({time.perf_counter() - t0:.0f} s)")
    say("2b. beds poured on the GPU, the CUDA path beside the CPU path at every core:")
    poured_throughput("16 per diameter", "quick", {}, 500, 90.0, particles_per_diameter=16.0)
    say("3. whole quick tests, CPU path at every core vs CUDA path, same seeds:")
    for seed in args.seeds:
        for dev in ("cpu", "cuda"):
            r = whole_test("quick", dev, seed, cores, 90.0)
            words = (f"C {r['C']:.0f} Pa, AIF {r['AIF']:.2f}°, ρ {r['rho']:.1f} kg/m³, {r['wall']:.0f} s wall"
                     if "C" in r else json.dumps(r)[:600])
            say(f"   seed {seed} {dev:4s}: {words}")
    left = args.budget_s - (time.perf_counter() - start) - 10.0
    say(f"4. the full converged cell (no sector) on the CUDA path, {left:.0f} s allowed:")
    if left > 120:
        poured_throughput("converged, full cell", "converged", {"sector": 1}, 200, min(120.0, left / 3))
        left = args.budget_s - (time.perf_counter() - start) - 10.0
    if left > 30:
        r = whole_test("converged", "cuda", 11, cores, left, sector=1)
        say("   " + (f"{r['n']} particles: {r['wall']:.0f} s wall; C {r['C']:.0f} Pa, AIF {r['AIF']:.2f}°, "
                     f"ρ {r['rho']:.1f} kg/m³; stage CPU {r['stage_cpu']}" if "C" in r else json.dumps(r)[:3000]))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "gpu_check.txt").write_text("\n".join(LINES) + "\n", encoding="utf-8")
    say(f"done in {time.perf_counter() - start:.0f} s; report in {out / 'gpu_check.txt'}")
    return 0


if __name__ == "__main__":
    os.environ.setdefault("NUMBA_ENABLE_CUDASIM", "0")
    sys.exit(main())
