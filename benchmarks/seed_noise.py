"""How noisy a cell is, and whether a metric's noise threshold holds: run one parameter point with
many seeds, print every feature's seed-to-seed spread, and (with --experiment) score each seed
against the experiment with each metric and count how many fall within the metric's threshold.

    .venv/bin/python benchmarks/seed_noise.py --preset tiny --seeds 100-107 --workers 2
    .venv/bin/python benchmarks/seed_noise.py --preset tiny --seeds 200-209 --set youngs_modulus=2e10 \\
        --set sliding_friction=0.35 --experiment examples/data/pseudo-numba-tiny.yaml --metric c_aif --metric robust

Compare cells and procedures side by side, in one run, by information per CPU-second: each
``--variant LABEL=JSON`` is the preset with those spec changes (as ``ShearCellSpec.replace`` takes
them); the table gives, per variant, the seed s.d. of the mean peak τ/σ, the preshears' τ/σ and the
bulk density, the CPU time per test and s²·CPU (lower: more information per CPU-second), and the
mean peak τ/σ of every seed:

    .venv/bin/python benchmarks/seed_noise.py --preset tiny --seeds 1-10 \
        --variant 'short windows={"procedure": {"shear_rotation": 0.2}}' --variant 'as preset={}'

Both print where the scatter comes from: a step's peak and preshear τ/σ split into what all four steps
of one test share (the packing the pour left) and what varies from step to step (the shearing's own
fluctuation), by an analysis of variance over seeds and steps (:func:`variance_split`).

Material defaults to Table 1 of the reference paper. Each seed's whole result is saved in the
--cache folder as it finishes, and a seed already there is not run again, so an interrupted run
resumes and a second metric costs no simulation. --spread-out writes the seed spread of the robust metric's features as a YAML
fragment for its ``seed_spread`` option. Seeds stay below calibrax.core.data.pseudo.EXPERIMENT_SEED_BASE.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np


def _seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def _spec(args: argparse.Namespace, seed: int, changes: dict | None = None):
    from calibrax import ShearCellSpec

    material = {k: float(v) for k, _, v in (s.partition("=") for s in args.set)}
    geometry = {k: float(v) if "." in v or "e" in v else int(v) for k, _, v in (s.partition("=") for s in args.geometry)}
    spec = ShearCellSpec.preset(args.preset, args.procedure, material=material, geometry=geometry)
    return spec.replace(**(changes or {})).replace(numerics={"seed": seed, "threads": 1}).validate()


def _variants(args: argparse.Namespace, parser: argparse.ArgumentParser) -> list[tuple[str, dict]]:
    """The ``--variant LABEL=JSON`` options as (label, spec changes); none: the preset alone."""
    out = []
    for text in args.variant:
        label, sep, blob = text.partition("=")
        try:
            changes = json.loads(blob) if sep else None
        except json.JSONDecodeError as exc:
            parser.error(f"--variant {text!r}: the part after '=' must be JSON spec changes ({exc})")
        if not label or not isinstance(changes, dict):
            parser.error(f"--variant {text!r}: give LABEL=JSON, e.g. 'long={{\"procedure\": {{\"shear_rotation\": 0.4}}}}'")
        out.append((label, changes))
    return out


def variance_split(per_step: np.ndarray) -> tuple[float, float]:
    """Split one feature's seed scatter into what the pour leaves and what the shearing adds.

    ``per_step`` has shape (seeds, steps): the feature of every step of every test (say the peak
    τ/σ of the four shear steps). Each step's own mean is removed (the steps differ in σ), then a
    one-way analysis of variance with the seeds as groups gives the s.d. shared by every step of
    one test (the packing the pour and consolidation left, "per seed") and the s.d. of one step about
    its test's mean (the shearing's own fluctuation, "per step"). Returns (per-seed s.d., per-step
    s.d.); a negative between-seed variance estimate is reported as 0.
    """
    a = np.asarray(per_step, dtype=float)
    a = a - a.mean(axis=0)
    n, k = a.shape
    if n < 2 or k < 2:
        return math.nan, math.nan
    between_ms = k * float(np.sum(a.mean(axis=1) ** 2)) / (n - 1)
    within_ms = float(np.sum((a - a.mean(axis=1, keepdims=True)) ** 2)) / (n * (k - 1))
    return math.sqrt(max((between_ms - within_ms) / k, 0.0)), math.sqrt(within_ms)


def sd_interval(values: np.ndarray, level: float = 0.9) -> tuple[float, float]:
    """The ``level`` confidence interval of the s.d. of normal draws from the sample ``values``
    (shape (n,)): √((n − 1) s² / χ²) at the two tail quantiles of χ² with n − 1 degrees of freedom.
    Ten seeds leave the s.d. uncertain by a factor of about 0.7–1.7 (90 %), which is why a table of
    s.d.s from ten seeds cannot tell 0.05 from 0.06. (NaN, NaN) below two values."""
    from scipy import stats

    v = np.asarray(values, dtype=float)
    n = v.size
    if n < 2:
        return math.nan, math.nan
    ss = (n - 1) * float(np.var(v, ddof=1))
    tail = (1.0 - level) / 2.0
    return math.sqrt(ss / stats.chi2.ppf(1.0 - tail, n - 1)), math.sqrt(ss / stats.chi2.ppf(tail, n - 1))


def print_variance_split(label: str, results: list) -> None:
    """One line per feature: the per-seed and per-step s.d. of :func:`variance_split`."""
    for name, values in (("peak τ/σ", [r.peak_shear_stress / r.peak_normal_stress for r in results]),
                         ("preshear τ/σ", [r.preshear_shear_stress / r.preshear_normal_stress for r in results])):
        seed_sd, step_sd = variance_split(np.asarray(values))
        share = seed_sd**2 / (seed_sd**2 + step_sd**2) if step_sd > 0 else math.nan
        print(f"{label}: {name} of one step scatters by {math.hypot(seed_sd, step_sd):.3f}: {seed_sd:.3f} shared by "
              f"the test's steps (the pour) and {step_sd:.3f} from step to step (the shearing); the pour's share "
              f"of the variance {share:.0%}")


def save_seed(folder: Path, seed: int, result) -> None:
    """``result`` whole into ``folder/seed_<seed>.h5``, written aside, then renamed (the cache's format)."""
    import h5py

    from calibrax.core.running.store import write_result_group

    tmp = folder / f".seed_{seed}.h5.tmp"
    with h5py.File(tmp, "w") as f:
        write_result_group(f.create_group("result"), result)
    tmp.rename(folder / f"seed_{seed}.h5")


def run_seed(args: argparse.Namespace, seed: int, folder: Path, changes: dict | None = None) -> int:
    """One simulation, saved whole to ``folder/seed_<seed>.h5`` (``save_seed``)."""
    from calibrax import get_manager

    spec = _spec(args, seed, changes)
    with tempfile.TemporaryDirectory() as work:
        result = get_manager().create("simulator", args.simulator).simulate(spec, Path(work))
    save_seed(folder, seed, result)
    return seed


def load_seed(folder: Path, seed: int, spec=None):
    """A saved seed's result; with ``spec``, read again off its steps with today's definitions (peaks,
    preshears' steady values), so that a cache made before a definition changed is still comparable
    (its engine warnings are dropped)."""
    import h5py

    from calibrax.core.sheartest import ShearTestResult
    from calibrax.core.running.store import read_result_group

    with h5py.File(folder / f"seed_{seed}.h5", "r") as f:
        result = read_result_group(f["result"])
    if spec is None:
        return result
    return ShearTestResult.from_steps(spec, list(result.steps), list(result.bulk_density), result.provenance)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--simulator", default="numba_dem")
    p.add_argument("--preset", default="tiny")
    p.add_argument("--procedure", default="paper")
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help="a material field")
    p.add_argument("--geometry", action="append", default=[], metavar="FIELD=VALUE", help="a geometry field")
    p.add_argument("--seeds", default="100-107", help="e.g. 100-107 or 1,5,9")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--cache", type=Path, help="folder of per-seed results, one HDF5 file each (default under runs/)")
    p.add_argument("--experiment", type=Path, help="score each seed against this experiment")
    p.add_argument("--metric", action="append", default=[], help="metric name (repeatable) for --experiment")
    p.add_argument("--spread-out", type=Path, help="write the robust metric's seed_spread YAML fragment here")
    p.add_argument("--spread-in", type=Path, help="score with the robust metric given this seed_spread fragment too")
    p.add_argument("--variant", action="append", default=[], metavar="LABEL=JSON",
                   help="compare variants of the preset side by side (spec changes as JSON, repeatable)")
    args = p.parse_args(argv)
    if args.variant:
        return compare(args, _variants(args, p))
    from calibrax.core.data.pseudo import EXPERIMENT_SEED_BASE

    seeds = _seeds(args.seeds)
    if max(seeds) >= EXPERIMENT_SEED_BASE:
        p.error(f"seeds must stay below {EXPERIMENT_SEED_BASE} (pseudo-experiments' seeds lie above)")
    spec = _spec(args, 0)
    folder = args.cache or Path("runs") / f"seed_noise-{args.simulator}-{args.preset}-{spec.spec_hash()}"
    folder.mkdir(parents=True, exist_ok=True)
    todo = [s for s in seeds if not (folder / f"seed_{s}.h5").exists()]
    print(f"{args.simulator}, {args.preset}: {len(seeds)} seeds ({len(todo)} to run, {args.workers} workers); "
          f"results in {folder}", file=sys.stderr)
    with cf.ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(run_seed, args, s, folder) for s in todo]
        for fut in cf.as_completed(futures):
            print(f"seed {fut.result()} done", file=sys.stderr)
    from calibrax.core.data.features import result_features

    results = [load_seed(folder, s, _spec(args, s)) for s in seeds]
    done = [{"features": result_features(r, spec.procedure.peak_window), "wall_s": r.provenance.wall_time,
             "base_slip": r.base_slip.tolist()} for r in results]
    from calibrax.core.data.features import FEATURES, feature_def, summarise

    summary = summarise(r["features"] for r in done)
    print(f"\n{args.simulator}, preset {args.preset}, material {args.set or 'Table 1'}, {len(done)} seeds "
          f"({min(seeds)}–{max(seeds)}), median wall {np.median([r['wall_s'] for r in done]):.0f} s per test\n")
    print("| feature | unit | mean | seed s.d. | s.d./|mean| | n |\n|---|---|---|---|---|---|")
    order = {stem: i for i, stem in enumerate(FEATURES)}
    for name in sorted(summary, key=lambda n: (order[feature_def(n).stem], n)):
        s = summary[name]
        rel = s.sd / abs(s.mean) if s.mean else math.nan
        print(f"| {name} | {feature_def(name).unit} | {s.mean:.4g} | {s.sd:.3g} | {rel:.1%} | {s.n} |")
    slips = np.asarray([r["base_slip"] for r in done], dtype=float)
    print()
    for name, values in variant_features(spec, results).items():
        lo, hi = sd_interval(values)
        print(f"{args.preset}: {name} {np.mean(values):.4g}, seed s.d. {np.std(values, ddof=1):.3g} [{lo:.3g}–{hi:.3g}] "
              f"(90 % CI), median {np.median(values):.4g}, over {values.size} seeds")
    print()
    print_variance_split(args.preset, results)
    print(f"\nbase slip (bottom layer's spin / head's rate): median {np.nanmedian(slips):.3f}, max {np.nanmax(slips):.3f}")
    if args.spread_out:
        from calibrax.plugins.builtin.metrics import RobustMetric

        agg = summarise(RobustMetric._aggregate(r["features"]) for r in done)
        fragment = {k: agg[k].sd for k in ("peak_ratio", "preshear_ratio", "bulk_density")}
        args.spread_out.write_text("seed_spread: {" + ", ".join(f"{k}: {v:.3g}" for k, v in fragment.items())
                                   + f"}}\nseed_spread_seeds: {len(done)}\n")
        print(f"wrote {args.spread_out}")
    if args.experiment:
        from calibrax import get_manager, load_experiment

        exp = load_experiment(args.experiment)
        print(f"\nagainst {args.experiment} (one seed per evaluation):\n")
        print("| metric | d per seed | threshold (95 %) | within | share |\n|---|---|---|---|---|")
        metrics = [(name, get_manager().create("metric", name)) for name in args.metric or ["c_aif"]]
        if args.spread_in:
            import yaml

            options = yaml.safe_load(args.spread_in.read_text())
            metrics.append((f"robust ({args.spread_in.name})", get_manager().create("metric", "robust", **options)))
        for name, metric in metrics:
            values = [metric.evaluate([r], exp) for r in results]
            d = [v.value for v in values]
            limit = values[0].threshold
            inside = sum(v.within_noise() for v in values)
            print(f"| {name} | {', '.join(f'{x:.2f}' for x in d)} | {limit:.3g} | {inside} of {len(d)} | "
                  f"{inside / len(d):.0%} |")
            print(f"\n{name}: {values[0].features.get('noise_threshold_how', '')}\n")
    return 0


def run_variant(args: argparse.Namespace, seeds: list[int], changes: dict) -> tuple[object, list]:
    """Run (or reuse) every seed of one variant; (its seed-0 spec, its results in seed order).
    Variants that differ only in how the peak is read (``procedure.peak_noise_correction``) share
    their runs: each is read again off the saved steps."""
    spec = _spec(args, 0, changes)
    run_hash = spec.replace(procedure={"peak_noise_correction": 0.0}).spec_hash()
    folder = args.cache or Path("runs") / f"seed_noise-{args.simulator}-{args.preset}-{run_hash}"
    if args.cache:
        folder = folder / run_hash
    folder.mkdir(parents=True, exist_ok=True)
    todo = [s for s in seeds if not (folder / f"seed_{s}.h5").exists()]
    with cf.ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(run_seed, args, s, folder, changes) for s in todo]
        for fut in cf.as_completed(futures):
            print(f"seed {fut.result()} done ({folder.name})", file=sys.stderr)
    return spec, [load_seed(folder, s, _spec(args, s, changes)) for s in seeds]


def compare(args: argparse.Namespace, variants: list[tuple[str, dict]]) -> int:
    """The side-by-side table of ``--variant`` runs: seed s.d., CPU per test, s²·CPU."""
    from calibrax.core.data.features import result_features, step_mean

    seeds = _seeds(args.seeds)
    rows = []
    for label, changes in variants:
        print(f"{label}: {len(seeds)} seeds, {args.workers} workers", file=sys.stderr)
        spec, results = run_variant(args, seeds, changes)
        feats = [result_features(r, spec.procedure.peak_window) for r in results]
        peak = np.asarray([step_mean(f, "peak_ratio") for f in feats])
        pre = np.asarray([step_mean(f, "preshear_ratio") for f in feats])
        rho = np.asarray([f["bulk_density"] for f in feats])
        cpu = float(np.median([r.provenance.wall_time * r.provenance.threads for r in results]))
        pre_rot = np.concatenate([r.preshear_rotation for r in results]) if results[0].preshear_rotation.size else np.array([np.nan])
        rows.append((label, spec, peak, pre, rho, cpu, pre_rot, results))
    print(f"\n{args.simulator}, preset {args.preset}, material {args.set or 'Table 1'}, seeds {args.seeds}; "
          "CPU: median per test on one thread; s²·CPU: seed variance × CPU s (lower is more information per CPU-second); "
          "[a–b]: the s.d.'s 90 % confidence interval (sd_interval)\n")
    print("| variant | particles | CPU s/test | peak τ/σ (mean of steps) | s.d. [90 % CI] | s²·CPU | preshear τ/σ | "
          "s.d. [90 % CI] | s²·CPU | bulk density s.d. [kg/m³] | preshear rotation [rad] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, spec, peak, pre, rho, cpu, pre_rot, _ in rows:
        sp, sq = float(np.std(peak, ddof=1)), float(np.std(pre, ddof=1))
        (p_lo, p_hi), (q_lo, q_hi) = sd_interval(peak), sd_interval(pre)
        print(f"| {label} | {spec.particle_count} | {cpu:.0f} | {np.mean(peak):.3f} | {sp:.3f} [{p_lo:.3f}–{p_hi:.3f}] | "
              f"{sp ** 2 * cpu:.3f} | {np.mean(pre):.3f} | {sq:.3f} [{q_lo:.3f}–{q_hi:.3f}] | {sq ** 2 * cpu:.3f} | "
              f"{np.std(rho, ddof=1):.1f} | {np.nanmin(pre_rot):.2f}–{np.nanmax(pre_rot):.2f} |")
    print()
    for label, _, peak, pre, *_ in rows:
        print(f"{label}: mean peak τ/σ per seed {', '.join(f'{v:.3f}' for v in peak)}")
        print(f"{label}: preshear τ/σ per seed {', '.join(f'{v:.3f}' for v in pre)}")
    print()
    for label, *_, results in rows:
        print_variance_split(label, results)
    print_equivalence([(label, spec, results) for label, spec, *_, results in rows])
    return 0


def mean_curve_peak(spec, results: list) -> float:
    """The peak τ/σ of the seeds' mean shear curve: every shear step's τ over its mean σ,
    averaged over steps and seeds sample by sample, then the maximum of its running mean over the
    peak window. Free of the noise that lifts each test's own peak (one value per variant)."""
    from calibrax.core.sheartest.peaks import running_mean, running_mean_width

    curves = [np.asarray(s.shear_stress) / float(np.mean(s.normal_stress))
              for r in results for s in r.steps if s.kind == "shear"]
    n = min(c.size for c in curves)
    mean = np.mean([c[:n] for c in curves], axis=0)
    step = next(s for s in results[0].steps if s.kind == "shear")
    return float(np.max(running_mean(mean, running_mean_width(step.rotation[:n], spec.procedure.peak_window))))


def variant_features(spec, results: list) -> dict[str, np.ndarray]:
    """The features a variant must keep, one value per seed (shape (seeds,)): the bulk density
    after the preshears (kg/m³, mean of steps), the mean peak and preshear τ/σ, the τ/σ at the end
    of the shear steps (past the peak, their last quarter), the test's τ/σ noise in the peak
    window (:func:`~calibrax.core.sheartest.peaks.peak_noise_ratio`, the figure
    ``procedure.peak_noise_correction`` scales), the yield locus's C (kPa) and AIF (°), and the
    CPU per test (s)."""
    from calibrax.core.data.features import result_features, step_mean
    from calibrax.core.sheartest.peaks import peak_noise_ratio

    window = spec.procedure.peak_window
    feats = [result_features(r, window) for r in results]
    loci = [r.yield_locus() for r in results]
    return {"bulk density [kg/m³]": np.asarray([f["bulk_density"] for f in feats]),
            "peak τ/σ": np.asarray([step_mean(f, "peak_ratio") for f in feats]),
            "preshear τ/σ": np.asarray([step_mean(f, "preshear_ratio") for f in feats]),
            "shear-end τ/σ": np.asarray([step_mean(f, "shear_end_ratio") for f in feats]),
            "τ/σ noise in the peak window": np.asarray(
                [peak_noise_ratio([s for s in r.steps if s.kind == "shear"], window) for r in results]),
            "C [kPa]": np.asarray([lo.cohesion / 1e3 for lo in loci]),
            "AIF [°]": np.asarray([lo.aif_deg for lo in loci]),
            "CPU [s/test]": np.asarray([r.provenance.wall_time * r.provenance.threads for r in results])}


def difference_interval(a: np.ndarray, b: np.ndarray, level: float = 0.9) -> tuple[float, float, float]:
    """(mean(b) − mean(a), and the ``level`` Welch confidence interval of it) for two samples of
    independent seeds, shapes (n,) and (m,)."""
    from scipy import stats

    va, vb = np.var(a, ddof=1) / a.size, np.var(b, ddof=1) / b.size
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1)) if va + vb > 0 else math.inf
    half = float(stats.t.ppf(0.5 + level / 2, dof) * math.sqrt(va + vb))
    d = float(np.mean(b) - np.mean(a))
    return d, d - half, d + half


def print_equivalence(rows: list) -> None:
    """Each feature of each variant against the first variant's (the reference): mean, seed s.d.
    with its 90 % interval, the difference with its 90 % Welch interval, and whether the two are
    equal within the seed noise (the difference's interval holds 0)."""
    print(f"\nagainst '{rows[0][0]}' (mean, seed s.d. [90 % CI of the s.d.], difference [90 % CI]; 'equal' when "
          "the difference's interval holds 0):\n")
    print("| feature | variant | seeds | mean | seed s.d. [90 % CI] | difference [90 % CI] | within noise |")
    print("|---|---|---|---|---|---|---|")
    reference = variant_features(rows[0][1], rows[0][2])
    for label, spec, results in rows:
        values = variant_features(spec, results)
        for name, v in values.items():
            lo, hi = sd_interval(v)
            cell = f"| {name} | {label} | {v.size} | {np.mean(v):.4g} | {np.std(v, ddof=1):.3g} [{lo:.3g}–{hi:.3g}] |"
            if label == rows[0][0]:
                print(cell + " reference | |")
                continue
            d, d_lo, d_hi = difference_interval(reference[name], v)
            same = "CPU" in name or d_lo <= 0.0 <= d_hi
            verdict = "" if "CPU" in name else ("equal" if same else "DIFFERENT")
            ratio = f" (×{np.mean(v) / np.mean(reference[name]):.2f})" if "CPU" in name else ""
            print(cell + f" {d:+.3g} [{d_lo:+.3g}, {d_hi:+.3g}]{ratio} | {verdict} |")
    print("\nthe peak τ/σ of the seeds' mean shear curve (mean_curve_peak; no seed's own noise in it): "
          + ", ".join(f"{label} {mean_curve_peak(spec, results):.3f}" for label, spec, results in rows))


if __name__ == "__main__":
    sys.exit(main())
