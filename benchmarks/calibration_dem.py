"""Full DEM calibration campaigns on a few targets (issue 18's target problem (b)): the longer
companion of benchmarks/calibration.py, on the real numba_dem engine instead of a response surface;
and, with ``mfei``, the DEM-level multi-fidelity benchmark (issue 51): a campaign across a cheap
level and the target cell against a campaign at the target alone.

    .venv/bin/python benchmarks/calibration_dem.py                              # 3 targets (hours)
    .venv/bin/python benchmarks/calibration_dem.py --targets 1 --budget 8 --strategies default,distance
    .venv/bin/python benchmarks/calibration_dem.py --preset converged --strategies default,mfei \
        --threads 2 --workers 1 --patience 2 --out runs/mf-dem              # days on 2 cores; resumable

For each target a true (E, μs) is drawn over the quickstart box (E on a log scale), numba_dem makes
a pseudo-experiment there (three seeds ≥ 2³⁰ as replicates, no campaign's, `--preset` cell, default
``tiny``; each replicate is stored as it ends), and each strategy runs a real campaign against it
(``calibrax run`` without the command line: the same config, store and executor), with the
``robust`` metric and 4 initial Sobol points then batches of q = 2, all strategies under the same
stopping rule (``--budget`` and ``--patience``: ``budget.patience``, stop once the answer has
settled). Everything lands in ``--out`` (default runs/calibration-dem/): the experiments, the
campaign files and stores; a second run resumes every store and re-simulates nothing, so it can
run in parts (a killed run loses at most the simulations in flight).

Strategies: ``default`` (the campaign's default: qEI, q = 2, on the composite model, the answer
recommended), ``distance`` (``surrogate: {model: distance}``: qEI on a Kriging model of the distance
itself), ``sobol`` (the best observation recommended), ``mfei`` (``fidelities: [--cheap, --preset]``:
8 Sobol points at the cheap level, the first 3 of them at the target too, then ``mfei`` batches of
q = 2 on the composite model with an AR(1) co-Kriging GP per feature, the answer read at the target).

Scored after every batch, from the store (the answer refitted on the points of the batches so far,
as the campaign itself computed it): the recommendation's parameter error on the unit cube (E on
its log scale), the CPU spent so far (every simulation's wall time × ``--threads``, all levels),
and the CPU until the μs error is at most ``--tolerance`` (unit cube, default 0.05, i.e. 0.04 in
μs) and stays so; where it never does, the campaign's whole CPU plus one simulation at the target
(marked "not reached"). Also where the answer ends: the final errors, and whether the truth lies
inside the answer's plausible interval of μs. There is no noise-free surface at the DEM level, so
the benchmark's χ² goal (benchmarks/calibration.py) cannot be computed here; the parameter error is
what a user would check against a known truth.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
STRATEGIES = ("default", "distance", "sobol", "mfei")
BOX = {"youngs_modulus": {"low": 5.0e9, "high": 5.0e10, "log": True},
       "sliding_friction": {"low": 0.1, "high": 0.9}}
MATERIAL = {"poisson_ratio": 0.25, "restitution": 0.3, "rolling_friction": 0.5, "density": 3000, "radius": 0.9e-3}


def truth(target: int) -> dict[str, float]:
    """The target's true parameters (natural units)."""
    u = np.random.default_rng(20_000 + target).random(2)
    return {"youngs_modulus": float(5.0e9 * 10.0 ** u[0]), "sliding_friction": float(0.1 + 0.8 * u[1])}


def make_experiment(target: int, preset: str, folder: Path, workers: int, threads: int = 1,
                    simulator: str = "numba_dem") -> Path:
    """The target's pseudo-experiment (made once; kept on later runs)."""
    from calibrax.core.data.pseudo import EXPERIMENT_SEED_BASE
    from calibrax.core.studies.pseudo_study import write_pseudo_experiment_resumably
    from calibrax.core.sheartest import ShearCellSpec

    out = folder / "experiment.yaml"
    if out.is_file():
        return out
    material = {k: v for k, v in {**MATERIAL, **truth(target)}.items() if k != "radius"}
    spec = ShearCellSpec.preset(preset, radius=MATERIAL["radius"], material=material, numerics={"threads": threads})
    return write_pseudo_experiment_resumably(spec, simulator, out, folder / "experiment-replicates.h5",
                                             replicates=3, first_seed=EXPERIMENT_SEED_BASE + 50_000 + 10 * target,
                                             cell_words=f"the {preset} preset", workers=workers)


def campaign_file(target: int, strategy: str, preset: str, budget: int, workers: int, folder: Path,
                  cheap: str = "tiny", threads: int = 1, patience: int = 0, simulator: str = "numba_dem") -> Path:
    """The strategy's campaign file for the target (written beside its experiment)."""
    iterations = max(0, (budget - 4) // 2)
    config = {
        "name": f"target-{target}-{strategy}", "simulator": simulator, "experiment": "experiment.yaml",
        "cell": {"preset": preset, "numerics": {"threads": threads}}, "material": MATERIAL, "parameters": BOX,
        "metric": "robust",
        "acquisition": {"name": "sobol" if strategy == "sobol" else "qei", "q": 2},
        "surrogate": {"model": "distance" if strategy == "distance" else "composite"},
        "budget": {"initial": 4, "iterations": iterations, **({"patience": patience} if patience else {})},
        "executor": {"name": "local", "workers": workers},
        "store": f"{strategy}.h5", "workdir": f"{strategy}.runs", "seed": target,
    }
    if strategy == "mfei":
        config["fidelities"] = [cheap, {"preset": preset, "initial": 3}]
        config["cell"] = {"numerics": {"threads": threads}}
        config["acquisition"] = {"name": "mfei", "q": 2}
        config["budget"]["initial"] = 8
    path = folder / f"{strategy}.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False), encoding="utf-8")
    return path


@dataclass
class Checkpoint:
    """The campaign after one batch: simulations per fidelity, CPU-seconds, the recommendation
    (unit cube) and the answer's plausible interval of μs (None where it has none)."""

    batch: int
    simulations: dict[str, int]
    cpu_s: float
    unit: np.ndarray
    mu_range: tuple[float, float] | None


def checkpoints(config, strategy: str, threads: int = 1) -> list[Checkpoint]:
    """One :class:`Checkpoint` per batch, from the store: the campaign's own answer on the points of
    the batches so far (Sobol: the best observation), the CPU of every simulation of those batches
    (wall time × ``threads``)."""
    from calibrax import CampaignStore
    from calibrax.core.search.points import campaign_answer

    points = sorted(CampaignStore(config.store).points(), key=lambda p: p.id)
    levels = config.plan.levels
    target = max(levels, key=levels.get) if levels else ""
    out = []
    for batch in sorted({p.batch for p in points}):
        upto = [p for p in points if p.batch <= batch]
        done = [p for p in upto if p.metric is not None and np.isfinite(p.metric.value)]
        at_target = [p for p in done if p.fidelity in ("", target)]
        if len(at_target) < 2:
            continue
        sims: dict[str, int] = {}
        for p in upto:
            sims[p.fidelity or config.spec.name] = sims.get(p.fidelity or config.spec.name, 0) + len(p.sims)
        cpu = sum(s.cpu_seconds(threads) for p in upto for s in p.sims if np.isfinite(s.wall_time))
        if strategy == "sobol":
            best = min(at_target, key=lambda p: p.metric.value)
            out.append(Checkpoint(batch, sims, cpu, best.unit, None))
            continue
        answer = campaign_answer(done, config.space, config.surrogate, config.seed, config.plan.levels)
        if answer is None:
            continue
        unit = config.space.to_unit(np.asarray([list(answer.params.values())]))[0]
        out.append(Checkpoint(batch, sims, cpu, unit, answer.ranges.get("sliding_friction")))
    return out


def cpu_to_reach(cps: list[Checkpoint], true_u: np.ndarray, tolerance: float, one_more: float) -> tuple[float, bool]:
    """CPU-seconds from which the μs error stays ≤ ``tolerance`` to the end, and whether it did;
    where it never does, the whole CPU plus ``one_more`` (one simulation at the target)."""
    reached = None
    for cp in reversed(cps):
        if abs(cp.unit[1] - true_u[1]) <= tolerance:
            reached = cp.cpu_s
        else:
            break
    return (reached, True) if reached is not None else (cps[-1].cpu_s + one_more, False)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--targets", type=int, default=3, help="target problems (truths)")
    ap.add_argument("--budget", type=int, default=16, help="simulations per campaign at the target (4 initial, "
                                                           "then batches of 2); mfei runs as many batches")
    ap.add_argument("--patience", type=int, default=0,
                    help="budget.patience of every campaign: stop once the answer has settled for this many "
                         "batches (0: the whole budget)")
    ap.add_argument("--strategies", default="default,distance,sobol", help=f"comma-separated, from {list(STRATEGIES)}")
    ap.add_argument("--preset", default="tiny", choices=("tiny", "quick", "converged", "paper"),
                    help="the target cell's fidelity (and the pseudo-experiments')")
    ap.add_argument("--cheap", default="tiny", help="mfei's cheap level (a fidelity preset cheaper than --preset)")
    ap.add_argument("--workers", type=int, default=2, help="simulations at once")
    ap.add_argument("--threads", type=int, default=1,
                    help="numerics.threads of every simulation (converged on 2 cores: --threads 2 --workers 1)")
    ap.add_argument("--simulator", default="numba_dem", help="the backend (its tests: the analytic test double)")
    ap.add_argument("--tolerance", type=float, default=0.05, help="μs error on the unit cube that counts as found")
    ap.add_argument("--out", type=Path, default=ROOT / "runs" / "calibration-dem", help="output folder")
    args = ap.parse_args(argv)
    from calibration import strategy_names  # benchmarks/calibration.py, beside this file

    names = strategy_names(args.strategies, STRATEGIES)
    if names is None:
        return 2
    if "mfei" in names and args.cheap == args.preset:
        print(f"error: --cheap {args.cheap} is the target itself; give a cheaper preset", file=sys.stderr)
        return 2
    from calibrax import CampaignStore, load_config, run_campaign
    from calibrax.core.fidelities import NOMINAL_COST_S

    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    rows = []
    t0 = time.perf_counter()
    one_more = NOMINAL_COST_S.get(args.preset, 0.0)
    for target in range(args.targets):
        folder = args.out / f"target-{target}"
        folder.mkdir(parents=True, exist_ok=True)
        true = truth(target)
        print(f"target {target}: truth E = {true['youngs_modulus'] / 1e9:.3g} GPa, μs = {true['sliding_friction']:.3g}",
              flush=True)
        make_experiment(target, args.preset, folder, args.workers, args.threads, args.simulator)
        true_u = np.array([np.log10(true["youngs_modulus"] / 5.0e9), (true["sliding_friction"] - 0.1) / 0.8])
        for strategy in names:
            config = load_config(campaign_file(target, strategy, args.preset, args.budget, args.workers, folder,
                                               args.cheap, args.threads, args.patience, args.simulator))
            run_campaign(config)
            cps = checkpoints(config, strategy, args.threads)
            cpu, reached = cpu_to_reach(cps, true_u, args.tolerance, one_more)
            final = np.abs(cps[-1].unit - true_u)
            mu = cps[-1].mu_range
            inside = "—" if mu is None else ("yes" if mu[0] <= true["sliding_friction"] <= mu[1] else "no")
            answer = CampaignStore(config.store).answer() if strategy != "sobol" else None
            claims = ", ".join(k for k, v in answer["constrained"].items() if v) or "none" if answer else "—"
            sims = cps[-1].simulations
            rows.append((strategy, target, cpu, reached, final[0], final[1], inside, claims, sims, cps[-1].cpu_s))
            print(f"  {strategy}: μs error ≤ {args.tolerance} from {cpu / 3600:.2f} CPU-h"
                  f"{'' if reached else ' (not reached)'}; final error E {final[0]:.3f}, μs {final[1]:.3f} (unit cube); "
                  f"truth inside the plausible μs: {inside}; constrained: {claims}; simulations {sims}, "
                  f"{cps[-1].cpu_s / 3600:.2f} CPU-h; per batch (CPU-h, μs error) "
                  + " ".join(f"({c.cpu_s / 3600:.2f}, {abs(c.unit[1] - true_u[1]):.2f})" for c in cps), flush=True)
    print(f"\n{args.targets} targets, budget {args.budget}, patience {args.patience}, target cell {args.preset}"
          f"{', cheap level ' + args.cheap if 'mfei' in names else ''}; {time.perf_counter() - t0:.0f} s\n")
    print("| strategy | targets | CPU-h to μs error ≤ tolerance: median (range) | reached | final μs error (median) | "
          "truth inside the plausible μs | simulations per level (median) | CPU-h in all (median) |")
    print("|---|---|---|---|---|---|---|---|")
    medians = {}
    for strategy in names:
        mine = [r for r in rows if r[0] == strategy]
        cpus = [r[2] / 3600 for r in mine]
        medians[strategy] = float(np.median(cpus))
        levels = sorted({k for r in mine for k in r[8]})
        per_level = ", ".join(f"{k} {np.median([r[8].get(k, 0) for r in mine]):.3g}" for k in levels)
        print(f"| {strategy} | {len(mine)} | {medians[strategy]:.2f} ({min(cpus):.2f}–{max(cpus):.2f}) | "
              f"{sum(r[3] for r in mine)}/{len(mine)} | {np.median([r[5] for r in mine]):.3f} | "
              f"{sum(r[6] == 'yes' for r in mine)}/{len(mine)} | {per_level} | "
              f"{np.median([r[9] / 3600 for r in mine]):.2f} |")
    if "mfei" in medians and "default" in medians and medians["default"] > 0:
        print(f"\nmfei's median CPU to the tolerance / default's: {medians['mfei'] / medians['default']:.2f} "
              "(issue 51's goal: ≤ 1/3)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
