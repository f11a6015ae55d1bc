"""Full DEM calibration campaigns on a few targets (issue 18's target problem (b)): the longer
companion of benchmarks/calibration.py, on the real numba_dem engine instead of a response surface.

    .venv/bin/python benchmarks/calibration_dem.py                              # 3 targets (hours)
    .venv/bin/python benchmarks/calibration_dem.py --targets 1 --budget 8 --strategies default,distance

For each target a true (E, μs) is drawn over the quickstart box (E on a log scale), numba_dem makes
a pseudo-experiment there (three seeds ≥ 2³⁰ as replicates, `--preset` cell, default ``tiny``),
and each strategy runs a real campaign against it (``calibrax run`` without the command line: the
same config, store and executor), with the ``robust`` metric and 4 initial Sobol points then
batches of q = 2. Everything lands in ``--out`` (default runs/calibration-dem/): the experiments,
the campaign files and stores; a second run resumes every store and re-simulates nothing.

Strategies: ``default`` (the campaign's default: qEI, q = 2, on the composite model, the answer
recommended), ``distance`` (``surrogate: {model: distance}``: qEI on a Kriging model of the distance
itself), ``sobol`` (the best observation recommended).

Scored after every batch, from the store (the answer refitted on the first n points, as the
campaign itself computed it): the recommendation's parameter error on the unit cube (E on its log
scale), and the simulations until the μs error is at most ``--tolerance`` (unit cube, default
0.05, i.e. 0.04 in μs) and stays so. There is no noise-free surface at the DEM level, so the
benchmark's χ² goal (benchmarks/calibration.py) cannot be computed here; the parameter error is
what a user would check against a known truth.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
STRATEGIES = ("default", "distance", "sobol")
BOX = {"youngs_modulus": {"low": 5.0e9, "high": 5.0e10, "log": True},
       "sliding_friction": {"low": 0.1, "high": 0.9}}
MATERIAL = {"poisson_ratio": 0.25, "restitution": 0.3, "rolling_friction": 0.5, "density": 3000, "radius": 0.9e-3}


def truth(target: int) -> dict[str, float]:
    """The target's true parameters (natural units)."""
    u = np.random.default_rng(20_000 + target).random(2)
    return {"youngs_modulus": float(5.0e9 * 10.0 ** u[0]), "sliding_friction": float(0.1 + 0.8 * u[1])}


def make_experiment(target: int, preset: str, folder: Path, workers: int) -> Path:
    """The target's pseudo-experiment (made once; kept on later runs)."""
    from calibrax.core.data.pseudo import EXPERIMENT_SEED_BASE, write_pseudo_experiment
    from calibrax.core.sheartest import ShearCellSpec

    out = folder / "experiment.yaml"
    if out.is_file():
        return out
    material = {k: v for k, v in {**MATERIAL, **truth(target)}.items() if k != "radius"}
    spec = ShearCellSpec.preset(preset, radius=MATERIAL["radius"], material=material, numerics={"threads": 1})
    return write_pseudo_experiment(spec, "numba_dem", out, replicates=3,
                                   first_seed=EXPERIMENT_SEED_BASE + 50_000 + 10 * target,
                                   cell_words=f"the {preset} preset", workers=workers)


def campaign_file(target: int, strategy: str, preset: str, budget: int, workers: int, folder: Path) -> Path:
    config = {
        "name": f"target-{target}-{strategy}", "simulator": "numba_dem", "experiment": "experiment.yaml",
        "cell": {"preset": preset, "numerics": {"threads": 1}}, "material": MATERIAL, "parameters": BOX,
        "metric": "robust",
        "acquisition": {"name": "sobol" if strategy == "sobol" else "qei", "q": 2},
        "surrogate": {"model": "distance" if strategy == "distance" else "composite"},
        "budget": {"initial": 4, "iterations": max(0, (budget - 4) // 2)},
        "executor": {"name": "local", "workers": workers},
        "store": f"{strategy}.h5", "workdir": f"{strategy}.runs", "seed": target,
    }
    path = folder / f"{strategy}.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False), encoding="utf-8")
    return path


def checkpoints(config, strategy: str) -> list[tuple[int, np.ndarray]]:
    """(simulations, the recommendation on the unit cube) after each batch, from the store: the
    campaign's own answer on its first n points (Sobol: the best observation)."""
    from calibrax import CampaignStore
    from calibrax.core.search.points import campaign_answer

    points = sorted(CampaignStore(config.store).points(), key=lambda p: p.id)
    done = [p for p in points if p.metric is not None and np.isfinite(p.metric.value)]
    out = []
    for n in range(4, len(done) + 1, 2):
        first = done[:n]
        if strategy == "sobol":
            out.append((n, min(first, key=lambda p: p.metric.value).unit))
            continue
        answer = campaign_answer(first, config.space, config.surrogate, config.seed,
                                 config.plan.levels)
        out.append((n, config.space.to_unit(np.asarray([list(answer.params.values())]))[0]))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--targets", type=int, default=3, help="target problems (truths)")
    ap.add_argument("--budget", type=int, default=16, help="simulations per campaign")
    ap.add_argument("--strategies", default=",".join(STRATEGIES), help=f"comma-separated, from {list(STRATEGIES)}")
    ap.add_argument("--preset", default="tiny", choices=("tiny", "quick", "paper"), help="the cell's fidelity")
    ap.add_argument("--workers", type=int, default=2, help="simulations at once")
    ap.add_argument("--tolerance", type=float, default=0.05, help="μs error on the unit cube that counts as found")
    ap.add_argument("--out", type=Path, default=ROOT / "runs" / "calibration-dem", help="output folder")
    args = ap.parse_args(argv)
    from calibration import strategy_names  # benchmarks/calibration.py, beside this file

    names = strategy_names(args.strategies, STRATEGIES)
    if names is None:
        return 2
    from calibrax import CampaignStore, load_config, run_campaign

    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    rows = []
    t0 = time.perf_counter()
    for target in range(args.targets):
        folder = args.out / f"target-{target}"
        folder.mkdir(parents=True, exist_ok=True)
        true = truth(target)
        print(f"target {target}: truth E = {true['youngs_modulus'] / 1e9:.3g} GPa, μs = {true['sliding_friction']:.3g}",
              flush=True)
        make_experiment(target, args.preset, folder, args.workers)
        true_u = np.array([np.log10(true["youngs_modulus"] / 5.0e9), (true["sliding_friction"] - 0.1) / 0.8])
        for strategy in names:
            config = load_config(campaign_file(target, strategy, args.preset, args.budget, args.workers, folder))
            run_campaign(config)
            cps = checkpoints(config, strategy)
            errors = [(n, np.abs(u - true_u)) for n, u in cps]
            reached = args.budget + 1
            for n, err in reversed(errors):
                if err[1] <= args.tolerance:
                    reached = n
                else:
                    break
            final = errors[-1][1]
            answer = CampaignStore(config.store).answer() if strategy != "sobol" else None
            claims = ", ".join(k for k, v in answer["constrained"].items() if v) or "none" if answer else "—"
            rows.append((strategy, target, reached, final[0], final[1], claims))
            print(f"  {strategy}: μs error ≤ {args.tolerance} from {reached} simulations; final error E "
                  f"{final[0]:.3f}, μs {final[1]:.3f} (unit cube); the answer calls constrained: {claims}; "
                  "per batch μs error " + " ".join(f"{e[1]:.2f}" for _, e in errors), flush=True)
    print(f"\n{args.targets} targets, budget {args.budget}, {args.preset}; {time.perf_counter() - t0:.0f} s\n")
    print("| strategy | targets | simulations to μs error ≤ tolerance (median, each) | final E error | final μs error | "
          "called constrained (each) |")
    print("|---|---|---|---|---|---|")
    for strategy in names:
        mine = [r for r in rows if r[0] == strategy]
        print(f"| {strategy} | {len(mine)} | {np.median([r[2] for r in mine]):.3g} ({', '.join(str(r[2]) for r in mine)}) | "
              f"{np.median([r[3] for r in mine]):.3f} | {np.median([r[4] for r in mine]):.3f} | "
              f"{'; '.join(r[5] for r in mine)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
