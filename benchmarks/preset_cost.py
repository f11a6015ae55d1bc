"""What one test of a fidelity preset costs on this machine: per test on a Dask worker, or one test
on several numba threads with the machine to itself. Each test's result is saved in
benchmarks/seed_noise.py's cache format (``seed_<n>.h5``), so the seeds join its noise table:

    .venv/bin/python benchmarks/preset_cost.py --preset converged --seeds 7,8 --dask 2 --cache runs/sn46conv
    .venv/bin/python benchmarks/preset_cost.py --preset converged --seeds 9 --threads 2 --cache runs/sn46conv
    .venv/bin/python benchmarks/seed_noise.py --preset converged --seeds 0-9 --cache runs/sn46conv

The one-thread cost is seed_noise's own (its pool runs one thread per test). CPU is the engine's
``stage_cpu`` (process CPU-seconds, all threads); wall is the engine's; "since submission" adds the
executor's overhead. Run nothing else meanwhile: the machines are noisy (docs/explanation/sector.md,
"The converged preset", has the figures)."""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from seed_noise import _seeds, save_seed  # noqa: E402  (seed_noise's seed syntax and cache format)


def cpu_s(result) -> float:
    """The test's CPU-seconds (its stages' process CPU, all threads)."""
    return float(sum(result.provenance.extra.get("stage_cpu", {}).values()))


def on_dask(preset: str, seeds: list[int], workers: int, folder: Path) -> None:
    """Every seed through calibrax's DaskExecutor on a LocalCluster of ``workers`` × 1 core."""
    from calibrax import ShearCellSpec
    from calibrax.core.running.dask_executor import DaskExecutor
    from calibrax.core.running.executor import SimulationTask

    executor = DaskExecutor(cluster="local", workers=workers, cores=1)
    work = Path(tempfile.mkdtemp(prefix="preset_cost-"))
    start = time.time()
    futures = {}
    for seed in seeds:
        spec = ShearCellSpec.preset(preset).replace(numerics={"seed": seed, "threads": 1}).validate()
        futures[seed] = executor.submit(SimulationTask(point_id=seed, simulator="numba_dem", spec=spec,
                                                       workdir=work / f"s{seed}"))
    try:
        for seed, future in futures.items():
            result = future.result()
            print(f"{preset} seed {seed} on a Dask worker: CPU {cpu_s(result):.0f} s, engine wall "
                  f"{result.provenance.wall_time:.0f} s, {time.time() - start:.0f} s since submission", flush=True)
            save_seed(folder, seed, result)
    finally:
        executor.shutdown()


def on_threads(preset: str, seeds: list[int], threads: int, folder: Path) -> None:
    """Each seed alone, one after another, on ``threads`` numba threads."""
    from calibrax import ShearCellSpec, get_manager

    for seed in seeds:
        spec = ShearCellSpec.preset(preset).replace(numerics={"seed": seed, "threads": threads}).validate()
        start = time.time()
        with tempfile.TemporaryDirectory() as work:
            result = get_manager().create("simulator", "numba_dem").simulate(spec, Path(work))
        stages = {k: round(v) for k, v in result.provenance.extra.get("stage_cpu", {}).items()}
        print(f"{preset} seed {seed} on {threads} thread{'s' if threads > 1 else ''}: wall {time.time() - start:.0f} s, CPU {cpu_s(result):.0f} s; "
              f"CPU by stage {stages}", flush=True)
        save_seed(folder, seed, result)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--preset", default="converged", help="a fidelity preset (default converged)")
    p.add_argument("--seeds", required=True, help="e.g. 7,8 or 5-9")
    how = p.add_mutually_exclusive_group(required=True)
    how.add_argument("--dask", type=int, metavar="WORKERS", help="run on a Dask LocalCluster of WORKERS × 1 core")
    how.add_argument("--threads", type=int, metavar="N", help="run each test alone on N numba threads")
    p.add_argument("--cache", type=Path, required=True, help="seed_noise's cache folder for this preset")
    args = p.parse_args(argv)
    args.cache.mkdir(parents=True, exist_ok=True)
    seeds = [s for s in _seeds(args.seeds) if not (args.cache / f"seed_{s}.h5").exists()]
    if not seeds:
        print(f"every seed of {args.seeds} is already in {args.cache}", file=sys.stderr)
        return 0
    if args.dask:
        on_dask(args.preset, seeds, args.dask, args.cache)
    else:
        on_threads(args.preset, seeds, args.threads, args.cache)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
