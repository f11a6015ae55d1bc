"""Multi-fidelity against single-fidelity search: CPU until the answer reaches the truth's noise.

    .venv/bin/python benchmarks/multifidelity.py                          # 12 targets, mfei and single
    .venv/bin/python benchmarks/multifidelity.py --targets 4 --strategies mfkg,mfei_lt

The problem is benchmarks/calibration.py's (read its docstring) at **two fidelities**: a response
surface with seed noise fitted to a real DEM design at ``quick`` (benchmarks/data/design-quick.csv)
and one at ``tiny`` over the same twelve (E, μs) points (benchmarks/data/design-tiny.csv, nested:
the same Sobol points, two seeds each, made with ``calibrax run`` on numba_dem; see its header).
A target draws a truth, makes a pseudo-experiment of three replicates at ``quick`` (the upper
fidelity), and each strategy calibrates against it; a simulation at a fidelity is that fidelity's
surface plus one draw of its seed noise, scored by the real ``robust`` metric, and costs that
fidelity's nominal CPU-seconds (calibrax.core.fidelities.NOMINAL_COST_S: 70 s at tiny, 250 s at
quick). After every batch the strategy's recommendation is scored as in calibration.py: E, the
surface's mean features at the recommendation against the experiment (E ≤ 2.80 is "as good as the
truth, 95 % of the time").

Printed per strategy, as medians and quartiles over the targets: the CPU-seconds until E ≤ 2.8
holds from then on (the budget plus one when never), the share of targets that reach it, the
simulations per fidelity, the final E/2.8 and the model's seconds per batch, and the ratio of the
median CPU to the single-fidelity campaign's.

Strategies: ``single`` (a campaign at quick alone: Sobol initial points, qEI q = 2 on the noise-aware
log1p Kriging model of the distance, ``surrogate: {model: distance}``), ``single_default`` (the
same with the composite model, the campaign's default), ``mfei`` (``fidelities: [tiny, quick]``:
8 Sobol points at tiny, the first 3 of them at quick, then Huang's augmented EI, q = 2, on the
composite model with an AR(1) co-Kriging GP per feature; the campaign's default), ``mfei_distance``
(the same on one AR(1) co-Kriging GP of the distance, ``surrogate: {model: distance}``), ``mfkg``
(BoTorch's multi-fidelity knowledge gradient on the distance model), ``mfei_lt`` (mfei_distance on
BoTorch's linear truncated fidelity kernel instead of AR(1)).
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from calibration import (DESIGN, T_EXPERIMENT, Problem, Surface, _quartiles, _reached, run_strategy,  # noqa: E402
                         space)

DESIGN_TINY = DESIGN.with_name("design-tiny.csv")
STRATEGIES = ("single", "single_default", "mfei", "mfei_distance", "mfkg", "mfei_lt")
MULTI = ("mfei", "mfei_distance", "mfkg", "mfei_lt")


@dataclass
class Run:
    """One strategy on one target: after each batch (CPU-s so far, E of the recommendation);
    simulations per fidelity; model seconds per batch."""

    checkpoints: list[tuple[float, float]] = field(default_factory=list)
    sims: dict[str, int] = field(default_factory=dict)
    overhead: list[float] = field(default_factory=list)


def run_single(name: str, problem: Problem, budget_cpu: float, cost: float, q: int, initial: int, seed: int) -> Run:
    """calibration.py's strategy at the upper fidelity alone, its simulations priced at ``cost``."""
    trace = run_strategy({"single": "distance", "single_default": "default"}[name], problem,
                         int(budget_cpu // cost), q, initial, seed)
    return Run([(n * cost, e) for n, _, e, _ in trace.checkpoints], {"quick": trace.checkpoints[-1][0]},
               trace.overhead)


def run_multi(name: str, problem: Problem, cheap: Surface, budget_cpu: float, costs: tuple[float, float], q: int,
              initial: tuple[int, int], seed: int) -> Run:
    """A two-fidelity campaign's loop: nested Sobol design, then the acquisition's (x, level)."""
    from calibrax.core.registry import get_manager
    from calibrax.core.search import surrogate
    from calibrax.core.search.acquisition import Observations
    from calibrax.core.search.answer import answer_from_model
    from calibrax.core.search.design import sobol_points
    from calibrax.core.search.multifidelity import MultiFidelityComposite, MultiFidelityKriging

    surrogate.FIDELITY_KERNEL = "linear_truncated" if name == "mfei_lt" else "ar1"
    acquisition = get_manager().create("acquisition", "mfkg" if name == "mfkg" else "mfei")
    sp = space()
    rng = np.random.default_rng(seed)
    surfaces = {0.0: cheap, 1.0: problem.surface}
    cost_of = {0.0: costs[0], 1.0: costs[1]}
    xs, levels, ys, terms = [], [], [], []
    run = Run(sims={"tiny": 0, "quick": 0})

    def simulate(batch: np.ndarray, level: float) -> None:
        for x, sim in zip(batch, surfaces[level].draw(batch, rng)):
            value = problem.metric.evaluate_features([sim], problem.replicates)
            xs.append(np.asarray(x, float))
            levels.append(level)
            ys.append(float(value.value))
            terms.append(value.terms())
            run.sims["quick" if level == 1.0 else "tiny"] += 1

    design = sobol_points(2, max(initial), seed=seed)
    simulate(design[:initial[0]], 0.0)
    simulate(design[:initial[1]], 1.0)
    while True:
        t0 = time.perf_counter()
        x, lv, y = np.stack(xs), np.asarray(levels), np.asarray(ys)
        model = (MultiFidelityComposite.fit_levels(x, lv, terms, y, seed=seed + len(ys)) if name == "mfei" else
                 MultiFidelityKriging.fit(x, lv, y, seed=seed + len(ys), threshold=problem.threshold))
        answer = answer_from_model(model, sp, problem.threshold, 0.95, len(ys))
        rec = sp.to_unit(np.asarray([list(answer.params.values())]))
        cpu = sum(cost_of[v] for v in levels)
        run.checkpoints.append((cpu, float(problem.against_experiment(rec)[0])))
        if cpu >= budget_cpu:
            break
        rows = acquisition.propose(model, sp, Observations(x, y, np.full(len(y), np.nan), lv), q,
                                   seed=seed + len(ys), fidelities=[(0.0, costs[0]), (1.0, costs[1])])
        run.overhead.append(time.perf_counter() - t0)
        for row in rows:
            simulate(row[:-1].reshape(1, -1), 1.0 if row[-1] > 0.5 else 0.0)
    return run


def _one(args: tuple) -> tuple[str, int, Run]:
    name, target, budget_cpu, q, initial, initial_mf, costs = args
    import torch

    torch.set_num_threads(1)
    upper, cheap = _surface(DESIGN), _surface(DESIGN_TINY)
    problem = Problem.make(upper, target)
    seed = 1000 * target + 7
    if name in MULTI:
        return name, target, run_multi(name, problem, cheap, budget_cpu, costs, q, initial_mf, seed)
    return name, target, run_single(name, problem, budget_cpu, costs[1], q, initial, seed)


_SURFACES: dict[Path, Surface] = {}


def _surface(path: Path) -> Surface:
    if path not in _SURFACES:
        _SURFACES[path] = Surface.fit(path)
    return _SURFACES[path]


def table(results: dict[str, list[Run]], budget_cpu: float) -> str:
    reached = {n: [_reached(r.checkpoints, T_EXPERIMENT, int(budget_cpu)) for r in runs] for n, runs in results.items()}
    base = float(np.median(reached["single"])) if "single" in reached else math.nan
    lines = ["| strategy | targets | CPU-s to E ≤ 2.8 (median [IQR]) | ÷ single's median | reached | "
             "simulations tiny / quick (median) | final E/2.8 | model s per batch |",
             "|---|---|---|---|---|---|---|---|"]
    for name, runs in results.items():
        med = float(np.median(reached[name]))
        sims = " / ".join(f"{np.median([r.sims.get(k, 0) for r in runs]):.0f}" for k in ("tiny", "quick"))
        lines.append(f"| {name} | {len(runs)} | {_quartiles(reached[name], '.0f')} | {med / base:.2f} | "
                     f"{sum(v <= budget_cpu for v in reached[name])}/{len(runs)} | {sims} | "
                     f"{_quartiles([r.checkpoints[-1][1] / T_EXPERIMENT for r in runs], '.2f')} | "
                     f"{_quartiles([float(np.mean(r.overhead)) if r.overhead else math.nan for r in runs])} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Problem and scoring: see the module docstring (benchmarks/multifidelity.py).")
    ap.add_argument("--targets", type=int, default=12, help="target problems (different truths and seeds)")
    ap.add_argument("--budget-cpu", type=float, default=0.0,
                    help="CPU-seconds per calibration (default: 24 simulations at the upper level)")
    ap.add_argument("--q", type=int, default=2, help="points per batch")
    ap.add_argument("--initial", type=int, default=4, help="initial points of the single-fidelity campaign")
    ap.add_argument("--initial-mf", default="8,3", help="initial points at tiny, at quick (nested)")
    ap.add_argument("--strategies", default="single,mfei", help=f"comma-separated, from {list(STRATEGIES)}")
    ap.add_argument("--costs", default="", help="CPU-s per simulation at the cheap and the upper level, 'CHEAP,UPPER' "
                                               "(default: the nominal tiny and quick costs, 70,250); a larger ratio "
                                               "prices the upper surface as a costlier cell")
    ap.add_argument("--workers", type=int, default=2, help="processes")
    args = ap.parse_args(argv)
    names = [s for s in args.strategies.split(",") if s]
    bad = [s for s in names if s not in STRATEGIES]
    if bad:
        print(f"error: --strategies: unknown {bad}; allowed: {list(STRATEGIES)}", file=sys.stderr)
        return 2
    try:
        initial_mf = tuple(int(v) for v in args.initial_mf.split(","))
        assert len(initial_mf) == 2 and initial_mf[0] >= 2 and initial_mf[1] >= 2
    except (ValueError, AssertionError):
        print(f"error: --initial-mf: give two integers ≥ 2, 'TINY,QUICK', got {args.initial_mf!r}", file=sys.stderr)
        return 2
    from calibrax.core.fidelities import NOMINAL_COST_S

    try:
        costs = tuple(float(v) for v in args.costs.split(",")) if args.costs else \
            (NOMINAL_COST_S["tiny"], NOMINAL_COST_S["quick"])
        assert len(costs) == 2 and 0 < costs[0] < costs[1]
    except (ValueError, AssertionError):
        print(f"error: --costs: give 'CHEAP,UPPER' CPU-s with 0 < CHEAP < UPPER, got {args.costs!r}", file=sys.stderr)
        return 2
    args.budget_cpu = args.budget_cpu or 24 * costs[1]
    for path in (DESIGN, DESIGN_TINY):
        s = _surface(path)
        print(f"surface from {path.name}: seed s.d. " + ", ".join(f"{k} {v:.3g}" for k, v in s.seed_sd.items()))
    jobs = [(n, t, args.budget_cpu, args.q, args.initial, initial_mf, costs) for t in range(args.targets) for n in names]
    results: dict[str, list[Run]] = {n: [] for n in names}
    t0 = time.perf_counter()
    with cf.ProcessPoolExecutor(args.workers) as pool:
        for k, (name, target, run) in enumerate(pool.map(_one, jobs), 1):
            results[name].append(run)
            reached = _reached(run.checkpoints, T_EXPERIMENT, int(args.budget_cpu))
            print(f"[{k}/{len(jobs)}] {name} target {target}: E ≤ 2.8 from {reached:.0f} CPU-s "
                  f"(sims {run.sims}), final E/2.8 {run.checkpoints[-1][1] / T_EXPERIMENT:.2f}", flush=True)
    print(f"\n{args.targets} targets, {args.budget_cpu:.0f} CPU-s each, costs {costs[0]:g} / {costs[1]:g} CPU-s per "
          f"simulation, initial {args.initial} (single) and {initial_mf[0]}/{initial_mf[1]} (multi), q = {args.q}; "
          f"{time.perf_counter() - t0:.0f} s\n")
    print(table(results, args.budget_cpu))
    return 0


if __name__ == "__main__":
    sys.exit(main())
