"""How many DEM simulations each search strategy needs to a trustworthy answer (issue 18).

    .venv/bin/python benchmarks/calibration.py                       # 20 targets, every strategy
    .venv/bin/python benchmarks/calibration.py --targets 2 --budget 8 --strategies default,sobol

The target problem is a **response surface with seed noise fitted to a real DEM design** at the
``quick`` fidelity (benchmarks/data/design-quick.csv, made by benchmarks/design_data.py: see its
header): for each feature of the ``robust`` metric (mean peak τ/σ, mean preshear τ/σ, bulk
density) a Kriging model of the seeds' values over (E, μs), whose fitted mean is the surface and
whose seed spread is the design's pooled seed-to-seed s.d. A target draws a true (E, μs) uniformly
over the box (E on a log scale), makes a pseudo-experiment of three replicates there (surface mean
plus seed noise), sets the metric's ``seed_spread`` to the design's (as a user would measure it with
benchmarks/seed_noise.py), and each strategy then calibrates against it: every "simulation" is the surface
at the point plus one draw of the seed noise, scored by the real ``robust`` metric. Strategies see
the same targets and the same experiment; each draws its own simulation noise.

For each strategy and target, after every batch the strategy's *recommendation* is scored twice:

* against the experiment's noise: E = √Σ ((f(x) − f̄_exp)/(σ/√n_exp))² with f the surface's mean
  features at the recommendation (what infinitely many seeds there would give), f̄_exp the
  replicates' mean and σ the true seed s.d.; at the truth E² is χ² with 3 degrees of freedom, so
  E ≤ T_exp = √χ²₃(0.95) = 2.80 says "the recommendation reproduces the experiment as well as the
  truth does, 95 % of the time". This is the benchmark's goal;
* against the metric's noise threshold T (one simulation's noise included, the campaign's own
  "within the noise"): D = the metric's distance of the surface's mean features, D ≤ T. One seed
  scatters about twice as much as a three-replicate mean, so T is about twice as wide and easy to
  meet.

A strategy has *reached* a criterion at n simulations when it holds at n and at every later batch.
Printed per strategy, as medians and quartiles over the targets: simulations to reach each
(budget + 1 when never reached within the budget), the final recommendation's parameter error (unit cube: E on its log scale), the final D / T, false
identifications (a parameter the answer calls constrained while the surface's own plausible region
spans ≥ 80 % of its range), and the overhead: seconds of model work per batch (Kriging fits,
acquisition optimisation and the answer's evaluation).

Strategies: ``default`` (the campaign's default: qEI, q = 2, on the composite Kriging model of
calibrax.core.search.composite, one GP per feature with the metric's seed spread as its noise prior, the
distance from their joint prediction, best_f from the expected distance at the evaluated points, the
answer's recommendation), ``distance`` (qEI, q = 2, on the noise-aware log1p Kriging model of the
distance itself, ``surrogate: {model: distance}``; the default before the composite model),
``qei_plain`` (the search before issue 18: qEI on a plain Kriging model of d with freely fitted
noise, best_f the best observation, the best observation recommended), ``qlogei``, ``qlognei`` (on
the distance model, the answer recommended), ``sobol`` and ``random`` (the best observation
recommended), ``sobol_model`` (Sobol points, the default model's recommendation), ``cma`` (CMA-ES
from the ``cma`` package, as ACCES uses; its mean recommended).
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import csv
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DESIGN = HERE / "data" / "design-quick.csv"
STEMS = ("peak_ratio", "preshear_ratio", "bulk_density")
#: √χ²₃(0.95): the truth's E stays below it 95 % of the time
T_EXPERIMENT = 2.7955
BOX = {"youngs_modulus": (5.0e9, 5.0e10, True), "sliding_friction": (0.1, 0.9, False)}
STRATEGIES = ("default", "distance", "qei_plain", "qlogei", "qlognei", "sobol", "sobol_model", "random", "cma")
#: the strategies whose model is the composite one (the campaign's default, calibrax.core.search.composite)
COMPOSITE = ("default", "sobol_model")
UNCONSTRAINED_SHARE = 0.8  # calibrax.core.search.answer's


# ----------------------------------------------------------------------------- the surface
def space():
    from calibrax.core.search.parameters import Parameter, ParameterSpace

    return ParameterSpace(tuple(Parameter(n, lo, hi, log=lg) for n, (lo, hi, lg) in BOX.items()))


def load_design(path: Path = DESIGN) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """The design's unit-cube points shape (n, 2), {stem: values (n,)} and point labels (n,) (rows
    of the same label are seeds of one point)."""
    rows = [r for r in csv.DictReader(line for line in path.open(encoding="utf-8") if not line.startswith("#"))]
    natural = np.array([[float(r["youngs_modulus"]), float(r["sliding_friction"])] for r in rows])
    unit = space().to_unit(natural)
    feats = {s: np.array([float(r[s]) for r in rows]) for s in STEMS}
    labels = np.array([r["point"] for r in rows])
    return unit, feats, labels


@dataclass
class Surface:
    """Per feature: a Kriging model of the seeds' values (its mean is the surface) and the
    design's pooled seed-to-seed s.d."""

    models: dict
    seed_sd: dict[str, float]
    seed_dof: int  # degrees of freedom of the pooled seed s.d.

    @classmethod
    def fit(cls, path: Path = DESIGN) -> "Surface":
        from calibrax.core.search.surrogate import Kriging

        unit, feats, labels = load_design(path)
        models, sds, dof = {}, {}, 0
        for stem, v in feats.items():
            # pooled within-point variance over the points with ≥ 2 seeds
            ss, dof = 0.0, 0
            for lab in np.unique(labels):
                w = v[labels == lab]
                if w.size > 1:
                    ss += float(np.sum((w - w.mean()) ** 2))
                    dof += w.size - 1
            sds[stem] = math.sqrt(ss / dof)
            models[stem] = Kriging.fit(unit, v, seed=0, transform="identity", noise_sd=sds[stem])
        return cls(models, sds, dof)

    def mean(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """The surface at unit points ``x`` shape (m, 2): {stem: (m,)}."""
        return {s: m.predict(np.atleast_2d(x))[0] for s, m in self.models.items()}

    def draw(self, x: np.ndarray, rng: np.random.Generator) -> list[dict[str, float]]:
        """One simulation (one seed) at each point of ``x``: the surface plus seed noise."""
        mean = self.mean(x)
        return [{s: float(mean[s][i] + self.seed_sd[s] * rng.standard_normal()) for s in STEMS}
                for i in range(len(np.atleast_2d(x)))]


@dataclass
class Problem:
    """One target: the truth, its pseudo-experiment, the metric and its threshold."""

    surface: Surface
    truth: np.ndarray  # unit cube, (2,)
    replicates: list[dict[str, float]]
    metric: object = None
    threshold: float = math.nan
    constrained: dict[str, bool] = field(default_factory=dict)

    @classmethod
    def make(cls, surface: Surface, target_seed: int, replicates: int = 3) -> "Problem":
        from calibrax.plugins.builtin.metrics import RobustMetric

        rng = np.random.default_rng(10_000 + target_seed)
        truth = rng.random(2)
        reps = surface.draw(np.repeat(truth.reshape(1, -1), replicates, axis=0), rng)
        # as a user would set it up: the seed spread measured beforehand (here: the design's), three
        # experimental replicates
        metric = RobustMetric(features=list(STEMS), seed_spread=dict(surface.seed_sd),
                              seed_spread_seeds=surface.seed_dof + 1)
        problem = cls(surface, truth, reps, metric)
        problem.threshold = problem.metric.evaluate_features(reps[:1], reps).threshold
        problem.constrained = problem._true_constraints()
        return problem

    def distance(self, sims: list[dict[str, float]]) -> float:
        return float(self.metric.evaluate_features(sims, self.replicates).value)

    def against_experiment(self, x: np.ndarray) -> np.ndarray:
        """E at unit points ``x`` (m, 2): the surface's mean features against the replicates' mean,
        each over σ/√n_exp with σ the true seed s.d. (χ with 3 dof at the truth)."""
        mean = self.surface.mean(x)
        n = len(self.replicates)
        z2 = sum(((mean[s] - np.mean([r[s] for r in self.replicates])) / (self.surface.seed_sd[s] / math.sqrt(n))) ** 2
                 for s in STEMS)
        return np.sqrt(z2)

    def noiseless(self, x: np.ndarray) -> np.ndarray:
        """D at unit points ``x`` (m, 2): the surface mean scored as one simulation."""
        mean = self.surface.mean(x)
        return np.array([self.distance([{s: float(mean[s][i]) for s in STEMS}]) for i in range(len(x))])

    def _true_constraints(self, n: int = 41) -> dict[str, bool]:
        """Per parameter: whether the surface's own plausible region (D ≤ T on a grid) spans less
        than :data:`UNCONSTRAINED_SHARE` of its range."""
        u = np.linspace(0, 1, n)
        grid = np.array(np.meshgrid(u, u)).reshape(2, -1).T
        inside = grid[self.noiseless(grid) <= self.threshold]
        if len(inside) == 0:
            return {name: True for name in BOX}
        return {name: bool(np.ptp(inside[:, j]) < UNCONSTRAINED_SHARE) for j, name in enumerate(BOX)}


# ----------------------------------------------------------------------------- strategies
@dataclass
class Trace:
    """One strategy on one target: after each batch, (simulations so far, the recommendation's D
    and E, the constraints it claims or None); the final recommendation; seconds of model work."""

    checkpoints: list[tuple[int, float, float, dict | None]] = field(default_factory=list)
    final: np.ndarray | None = None
    overhead: list[float] = field(default_factory=list)


def _model(x: np.ndarray, y: np.ndarray, threshold: float, plain: bool, seed: int):
    from calibrax.core.search.surrogate import Kriging, noise_sd_from_threshold

    if plain:
        return Kriging.fit(x, y, seed=seed, transform="identity")
    return Kriging.fit(x, y, seed=seed, transform="log1p", noise_sd=noise_sd_from_threshold(threshold))


def _checkpoint(problem: Problem, n: int, rec: np.ndarray, claims: dict | None) -> tuple:
    x = rec.reshape(1, -1)
    return n, float(problem.noiseless(x)[0]), float(problem.against_experiment(x)[0]), claims


def run_strategy(name: str, problem: Problem, budget: int, q: int, initial: int, seed: int) -> Trace:
    """Calibrate against ``problem`` with ``budget`` simulations in batches of ``q``."""
    from calibrax.core.search.acquisition import Observations
    from calibrax.core.search.answer import answer_from_model
    from calibrax.core.search.composite import CompositeKriging
    from calibrax.core.search.design import sobol_points
    from calibrax.core.registry import get_manager

    sp = space()
    rng = np.random.default_rng(seed)  # this strategy's simulation noise
    trace = Trace()
    acquisition = None
    if name in ("default", "distance", "qei_plain", "qlogei", "qlognei"):
        acq = {"default": ("qei", {}), "distance": ("qei", {}), "qei_plain": ("qei", {"best_f": "observed"}),
               "qlogei": ("qlogei", {}), "qlognei": ("qlognei", {})}[name]
        acquisition = get_manager().create("acquisition", acq[0], **acq[1])
    es = None
    if name == "cma":
        import cma

        es = cma.CMAEvolutionStrategy([0.5, 0.5], 0.3, {"bounds": [0, 1], "popsize": max(q, 4), "seed": seed + 1,
                                                         "verbose": -9})
    xs: list[np.ndarray] = []
    ys: list[float] = []
    terms: list[dict] = []

    def simulate(batch: np.ndarray) -> None:
        for x, sim in zip(batch, problem.surface.draw(batch, rng)):
            value = problem.metric.evaluate_features([sim], problem.replicates)
            xs.append(np.asarray(x, float))
            ys.append(float(value.value))
            terms.append(value.terms())

    def recommend() -> tuple[np.ndarray, dict | None]:
        x, y = np.stack(xs), np.asarray(ys)
        if name in ("default", "distance", "qlogei", "qlognei", "sobol_model"):
            t0 = time.perf_counter()
            model = (CompositeKriging.fit(x, terms, y, seed=seed) if name in COMPOSITE
                     else _model(x, y, problem.threshold, False, seed))
            answer = answer_from_model(model, sp, problem.threshold, 0.95, len(y))
            trace.overhead.append(time.perf_counter() - t0)
            return sp.to_unit(np.asarray([list(answer.params.values())]))[0], dict(answer.constrained)
        if name == "cma":
            return np.clip(np.asarray(es.result.xfavorite), 0, 1), None
        return x[int(np.argmin(y))], None

    if es is not None:
        while len(xs) < budget:
            asked = es.ask()
            batch = np.clip(np.asarray(asked), 0, 1)[: budget - len(xs)]
            n0 = len(ys)
            simulate(batch)
            if len(batch) == len(asked):
                es.tell(asked, ys[n0:])
            rec, claims = recommend()
            trace.checkpoints.append(_checkpoint(problem, len(xs), rec, claims))
        trace.final = rec
        return trace
    first = (rng.random((initial, 2)) if name == "random" else sobol_points(2, initial, seed=seed))
    simulate(first)
    while True:
        rec, claims = recommend()
        trace.checkpoints.append(_checkpoint(problem, len(xs), rec, claims))
        if len(xs) >= budget:
            break
        k = min(q, budget - len(xs))
        if name == "random":
            batch = rng.random((k, 2))
        elif name in ("sobol", "sobol_model"):
            batch = sobol_points(2, k, seed=seed, skip=len(xs))
        else:
            t0 = time.perf_counter()
            x, y = np.stack(xs), np.asarray(ys)
            model = (CompositeKriging.fit(x, terms, y, seed=seed + len(xs)) if name in COMPOSITE
                     else _model(x, y, problem.threshold, name == "qei_plain", seed + len(xs)))
            obs = Observations(x, y, np.full(len(y), np.nan))
            batch = acquisition.propose(model, sp, obs, k, seed=seed + len(xs))
            trace.overhead.append(time.perf_counter() - t0)
        simulate(batch)
    trace.final = rec
    return trace


# ----------------------------------------------------------------------------- scoring
@dataclass
class Score:
    reached: int  # simulations until E ≤ T_EXPERIMENT from then on; budget + 1 if never
    reached_metric: int  # the same for D ≤ T (the metric's threshold)
    error_e: float  # |Δu| of E (log scale) of the final recommendation
    error_mu: float
    final_ratio: float  # final E / T_EXPERIMENT
    false_ids: int  # parameters claimed constrained that the surface leaves unconstrained
    overhead: float  # seconds of model work (fits, acquisition, answers) per batch (nan: none)


def _reached(values: list[tuple[int, float]], limit: float, budget: int) -> int:
    reached = budget + 1
    for n, v in reversed(values):
        if v <= limit:
            reached = n
        else:
            break
    return reached


def score(trace: Trace, problem: Problem, budget: int) -> Score:
    cps = trace.checkpoints
    reached = _reached([(c[0], c[2]) for c in cps], T_EXPERIMENT, budget)
    reached_metric = _reached([(c[0], c[1]) for c in cps], problem.threshold, budget)
    claims = cps[-1][3] or {}
    false_ids = sum(1 for k, v in claims.items() if v and not problem.constrained.get(k, True))
    err = np.abs(trace.final - problem.truth)
    return Score(reached, reached_metric, float(err[0]), float(err[1]), cps[-1][2] / T_EXPERIMENT, false_ids,
                 sum(trace.overhead) / max(1, len(trace.checkpoints) - 1) if trace.overhead else math.nan)


def _one(args: tuple[str, int, int, int, int, str]) -> tuple[str, int, Score]:
    name, target, budget, q, initial, design = args
    import torch

    torch.set_num_threads(1)
    surface = _surface(design)
    problem = Problem.make(surface, target)
    trace = run_strategy(name, problem, budget, q, initial, seed=1000 * target + 7)
    return name, target, score(trace, problem, budget)


_SURFACES: dict[str, Surface] = {}


def _surface(design: str) -> Surface:
    if design not in _SURFACES:
        _SURFACES[design] = Surface.fit(Path(design))
    return _SURFACES[design]


def _quartiles(v: list[float], fmt: str = ".3g") -> str:
    """"median [q1–q3]" of the finite values, in ``fmt``."""
    a = np.asarray(v, float)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return "—"
    q1, med, q3 = np.percentile(a, [25, 50, 75])
    return f"{med:{fmt}} [{q1:{fmt}}–{q3:{fmt}}]"


def table(results: dict[str, list[Score]], budget: int) -> str:
    lines = ["| strategy | targets | simulations to E ≤ 2.8 (median [IQR]) | reached | simulations to D ≤ T | "
             "E error (unit) | μs error | final E/2.8 | false identifications | model s per batch |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, scores in results.items():
        lines.append(
            f"| {name} | {len(scores)} | {_quartiles([s.reached for s in scores])} | "
            f"{sum(s.reached <= budget for s in scores)}/{len(scores)} | "
            f"{_quartiles([s.reached_metric for s in scores])} | {_quartiles([s.error_e for s in scores])} | "
            f"{_quartiles([s.error_mu for s in scores])} | {_quartiles([s.final_ratio for s in scores])} | "
            f"{sum(s.false_ids for s in scores)} | {_quartiles([s.overhead for s in scores])} |")
    return "\n".join(lines)


def strategy_names(text: str, allowed: tuple[str, ...]) -> list[str] | None:
    """The comma-separated ``--strategies``, or None (with the error printed) when one is unknown."""
    names = [s for s in text.split(",") if s]
    bad = [s for s in names if s not in allowed]
    if bad:
        print(f"error: --strategies: unknown {bad}; allowed: {list(allowed)}", file=sys.stderr)
        return None
    return names


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Problem and scoring: see the module docstring (benchmarks/calibration.py).")
    ap.add_argument("--targets", type=int, default=20, help="target problems (different truths and seeds)")
    ap.add_argument("--budget", type=int, default=24, help="simulations per calibration")
    ap.add_argument("--q", type=int, default=2, help="points per batch")
    ap.add_argument("--initial", type=int, default=4, help="initial space-filling points")
    ap.add_argument("--strategies", default=",".join(STRATEGIES), help=f"comma-separated, from {list(STRATEGIES)}")
    ap.add_argument("--workers", type=int, default=2, help="processes")
    ap.add_argument("--design", default=str(DESIGN), help="the DEM design's CSV")
    args = ap.parse_args(argv)
    names = strategy_names(args.strategies, STRATEGIES)
    if names is None:
        return 2
    surface = _surface(args.design)
    print(f"surface from {args.design}: seed s.d. " + ", ".join(f"{k} {v:.3g}" for k, v in surface.seed_sd.items()))
    jobs = [(n, t, args.budget, args.q, args.initial, args.design) for t in range(args.targets) for n in names]
    results: dict[str, list[Score]] = {n: [] for n in names}
    t0 = time.perf_counter()
    with cf.ProcessPoolExecutor(args.workers) as pool:
        for k, (name, target, s) in enumerate(pool.map(_one, jobs), 1):
            results[name].append(s)
            print(f"[{k}/{len(jobs)}] {name} target {target}: E ≤ 2.8 from {s.reached} simulations "
                  f"(D ≤ T from {s.reached_metric}), final E/2.8 {s.final_ratio:.2f}",
                  flush=True)
    print(f"\n{args.targets} targets, budget {args.budget}, q = {args.q}, {args.initial} initial points; "
          f"{time.perf_counter() - t0:.0f} s\n")
    print(table(results, args.budget))
    return 0


if __name__ == "__main__":
    sys.exit(main())
