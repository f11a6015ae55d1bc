"""The ``calibrax`` command: parses, calls the library, prints. No logic of its own."""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import signal
import warnings
import sys
from pathlib import Path

import yaml

EXAMPLES = """\
examples:
  calibrax run examples/quickstart.yaml            run (or resume) a campaign
  calibrax run examples/quickstart.yaml --check    validate it and print the resolved settings
  calibrax status runs/quickstart.h5               points, results and the answer so far
  calibrax export runs/quickstart.h5               trials as CSV (runs/quickstart-trials.csv)
  calibrax report runs/quickstart.h5               HTML page and figures (runs/quickstart.report/)
  calibrax diagnose runs/quickstart.h5             where the sim-to-real gap lies and which effect causes it
  calibrax diagnose-benchmark                      score the diagnosis blind on cases with a withheld effect
  calibrax sensitivity runs/quickstart.h5          what the test can see: feature shifts in noise units
  calibrax plugins                                 registered simulators, metrics, acquisitions…
"""


def build_parser() -> argparse.ArgumentParser:
    from calibrax import __version__

    p = argparse.ArgumentParser(
        prog="calibrax",
        description="Calibrate DEM parameters (E, μs, …) against a measured FT4 shear test with Efficient "
                    "Global Optimisation: a Kriging model and q-point Expected Improvement.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"calibrax {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    run = sub.add_parser("run", help="run or resume a calibration campaign",
                         description="Run the campaign of CONFIG, or resume it from its store: finished "
                                     "simulations are never repeated. It ends with the answer: the Kriging "
                                     "model's recommendation, the plausible range of each parameter and "
                                     "whether the test constrains it (docs/explanation/answer.md)"
                                     ". Exit codes: 0 done, 2 bad input, 1 other error, 130 stopped "
                                     "(run again to resume).")
    run.add_argument("config", type=Path, help="campaign YAML file (docs/reference/campaign-file.md)")
    run.add_argument("--check", action="store_true",
                     help="validate CONFIG and every file it names, print the resolved settings, run nothing")
    run.add_argument("--workers", type=int, metavar="N", help="simulations at once (overrides executor.workers)")
    run.add_argument("-q", "--quiet", action="store_true", help="print only warnings and the final summary")
    run.add_argument("--json", action="store_true",
                     help="print progress as JSON lines on stdout (one event per line: campaign, warm_start, proposed, "
                          "started, running, done, failed, model, answer, summary); human logs are silenced")

    status = sub.add_parser("status", help="show a campaign store: points, results, the answer",
                            description="A table of every point of the store: parameters, status, C, AIF, "
                                        "distance, wall time; then the answer (recommendation, plausible "
                                        "ranges, what the test constrains) and the best observed point.")
    status.add_argument("store", type=Path, help="the campaign's HDF5 store")
    status.add_argument("--json", action="store_true", help="print machine-readable JSON instead of a table")

    export = sub.add_parser("export", help="write a campaign's trials as CSV (one row per point)",
                            description="One row per parameter point: id, batch, source, state, the parameters "
                                        "(with units in the column names), distance and its s.d., the noise "
                                        "threshold and whether the point is within it, simulated and measured C "
                                        "and AIF, seeds, the engines' wall time, the mean peak τ per σ and the "
                                        "failures. Empty cells where nothing is known.")
    export.add_argument("store", type=Path, help="the campaign's HDF5 store")
    export.add_argument("-o", "--output", type=Path, metavar="FILE",
                        help="CSV file to write (default: STORE-trials.csv next to the store)")

    cross = sub.add_parser("crosscheck", help="run the same shear test on several backends and compare",
                           description="Run the campaign's shear-test spec at the same parameter points on each "
                                       "backend with N seeds (through the campaign's executor), plus the micro-level "
                                       "checks of every backend (two-sphere collision, sliding, rolling); write a "
                                       "table (crosscheck.md) and a figure (C–AIF plane, one marker per backend, "
                                       "error ellipses) and say where backends disagree beyond their uncertainty.")
    cross.add_argument("config", type=Path, help="campaign YAML file (cell, material, executor are used)")
    cross.add_argument("--backends", required=True, help="comma-separated simulators, e.g. numba_dem,liggghts,yade")
    cross.add_argument("--seeds", type=int, default=3, help="seeds per point and backend (default 3)")
    cross.add_argument("--points", action="append", default=[], metavar="NAME=V,...",
                       help="a parameter point, e.g. youngs_modulus=2.5e10,geometry.wall_friction=0.2 (any name a "
                            "campaign may calibrate; repeatable; default: the campaign's cell)")
    cross.add_argument("--no-micro", action="store_true", help="skip the micro-level checks")
    cross.add_argument("-o", "--output", type=Path, metavar="DIR", help="output folder (default: STORE.crosscheck/)")
    cross.add_argument("--workers", type=int, metavar="N", help="simulations at once (overrides executor.workers)")

    conv = sub.add_parser("converge", help="fidelity study: particles per diameter (at constant inertial number), "
                                           "time step, shear rate or inertial number",
                          description="Run the campaign's spec at several fidelity settings with N seeds each and "
                                      "state the cheapest setting whose C, AIF, bulk density and robust features "
                                      "(peak and preshear τ/σ) lie within the uncertainty of the finest (bulk "
                                      "density: at least within 2 %) "
                                      "(converge.md, converge.png/svg).")
    conv.add_argument("config", type=Path, help="campaign YAML file")
    conv.add_argument("--particles-per-diameter", metavar="LIST", help="e.g. 15,20,25,34 (the paper: 25,34,46,63)")
    conv.add_argument("--dt-fraction", metavar="LIST", help="fractions of the critical time step, e.g. 0.05,0.1,0.2")
    conv.add_argument("--shear-rate", metavar="LIST", help="head rotation rates in rad/s, e.g. 0.5,1,2")
    conv.add_argument("--inertial-number", metavar="LIST",
                      help="inertial numbers at the preshear stress (the rate derived for the cell), "
                           "e.g. 2e-4,5e-4,1e-3 (tiny: 1.4e-3, paper: 4.4e-4)")
    conv.add_argument("--seeds", type=int, default=3, help="seeds per setting (default 3)")
    conv.add_argument("--backend", help="simulator (default: the campaign's)")
    conv.add_argument("-o", "--output", type=Path, metavar="DIR", help="output folder (default: STORE.converge/)")
    conv.add_argument("--workers", type=int, metavar="N", help="simulations at once (overrides executor.workers)")

    diag = sub.add_parser("diagnose", help="diagnose the sim-to-real gap of a calibrated campaign",
                          description="Where the gap between the calibrated model and the experiment lies (each "
                                      "feature's standardised residual, |z| > 3 implausible), which unmodelled "
                                      "effect causes it (each candidate fitted jointly with the calibrated parameters "
                                      "on a DEM design around the campaign's answer and scored by its Bayes factor "
                                      "against 'no effect'; the answer can also be 'no effect' or 'none of the "
                                      "candidates'), and how far the gap shrinks once the top effect is added "
                                      "(recalibrated on some feature groups, judged on the others with fresh seeds). "
                                      "Writes DIR/diagnosis.md, diagnosis.json, figures and the simulations' stores "
                                      "(design-*.h5, confirm-*.h5): run it again to resume. The campaign report "
                                      "includes it. docs/tutorials/diagnose-the-gap.md.")
    diag.add_argument("store", type=Path, help="the calibrated campaign's HDF5 store (it must have an answer)")
    diag.add_argument("--effects", metavar="LIST",
                      help="comma-separated candidate effects (default: every registered one the backend can "
                           "model; builtin: wall_friction, size_distribution, cohesion)")
    diag.add_argument("--backend", help="the diagnosing simulator (default: the campaign's)")
    diag.add_argument("--budget", type=int, metavar="N",
                      help="simulations in all (default 4 replicates + 4 baseline + 8 per effect + 4 to confirm: "
                           "36 for three effects). A multi-fidelity campaign is diagnosed across its fidelities: "
                           "the design at the cheapest, 2 replicates and 2 confirmations at the target "
                           "(docs/explanation/diagnosis.md#across-fidelities)")
    diag.add_argument("--fit-on", default="locus,density", metavar="GROUPS",
                      help="feature groups the recalibration is fitted to; the others judge it. Groups: locus (peak "
                           "τ/σ per step), density (bulk density after the preshear, conditioned bulk density), "
                           "compressibility (CPS at the ramp's top stress), flow (preshear and post-peak τ/σ), shape "
                           "(initial slope and peak prominence of the τ curves). Default: locus,density")
    diag.add_argument("--seed", type=int, default=0, help="the design's seed (default 0)")
    diag.add_argument("-o", "--output", type=Path, metavar="DIR", help="output folder (default: STORE.diagnosis/)")
    diag.add_argument("--workers", type=int, metavar="N", help="simulations at once (overrides executor.workers)")

    bench = sub.add_parser("diagnose-benchmark", help="score the diagnosis blind, on cases whose effect is withheld",
                           description="Make cases with one hidden effect (small, medium, large), controls with "
                                       "none, cases with an effect outside the candidate list and (emulator level) "
                                       "cases made with a procedure or an engine the design never saw, diagnose each "
                                       "from its data alone, and score the answers against a labels file the "
                                       "diagnosis never reads: top-1 and top-2 accuracy, the confusion matrix, false "
                                       "alarms, unlisted effects rejected, mismatches answered \"none of the "
                                       "candidates\" beyond the noise, the recovered magnitude's error and the "
                                       "held-out shrinkage against the oracle's. Writes DIR/scores.md, scores.json, "
                                       "confusion.png, answers.json and labels.yaml. docs/explanation/diagnosis-benchmark.md.")
    bench.add_argument("--level", default="emulator", choices=["emulator", "dem"],
                       help="emulator: a response surface of the shipped DEM design stands in for the simulator "
                            "(minutes); dem: cases made and diagnosed with real simulations, resumable (hours). "
                            "Default: emulator")
    bench.add_argument("--model", type=Path, metavar="FILE",
                       help="the calibrated model every case is diagnosed against (default: the shipped tiny "
                            "numba_dem model, calibrax/diagnosis/benchmark/data/tiny.yaml)")
    bench.add_argument("--design", type=Path, metavar="FILE",
                       help="emulator level: the DEM design's data (default: the shipped design-tiny.json)")
    bench.add_argument("--per-class", type=int, metavar="N",
                       help="cases per class, per magnitude for a listed effect (default: 30 emulator, 3 dem)")
    bench.add_argument("--also", action="append", metavar="BACKEND:CLASSES",
                       help="dem level: make these classes on another truth backend too (repeatable; default "
                            "liggghts:wall_friction; off: the model's backend only)")
    bench.add_argument("--cases", type=Path, metavar="DIR",
                       help="score an external folder of experiment files (CASE.yaml with its CSVs) instead of "
                            "making cases; needs --labels")
    bench.add_argument("--labels", type=Path, metavar="FILE",
                       help="the labels of --cases (YAML: cases: [{case, class, expected, effects, params}])")
    bench.add_argument("--answers", type=Path, metavar="FILE",
                       help="score these answers (an answers.json of an earlier run) against --labels; runs nothing")
    bench.add_argument("--seed", type=int, default=0, help="cases' and measurement noise's seed (default 0)")
    bench.add_argument("--workers", type=int, metavar="N", help="dem level: simulations at once (default 1)")
    bench.add_argument("-o", "--output", type=Path, metavar="DIR",
                       help="output folder (default: runs/diagnose-benchmark-LEVEL/)")

    sens = sub.add_parser("sensitivity", help="what a test can see: each feature's seed noise and shift per "
                                              "parameter and per effect, in noise units",
                          description="Before buying simulations for a diagnosis: at a calibrated point (a campaign "
                                      "store's answer, or a model file as diagnose-benchmark --model takes), the "
                                      "diagnosis's DEM design is run around it (resumable: run it again to carry on) "
                                      "and each feature's seed noise and its shift for a 10 % step of each "
                                      "calibrated parameter and for each candidate effect at its small, medium and "
                                      "large magnitude are tabled in noise units of an n-replicate mean; ≥ 3 is what "
                                      "a diagnosis can see. Writes sensitivity.md, sensitivity.json and a heat map "
                                      "(sensitivity.png/.svg). With no SOURCE: the blind benchmark's shipped model "
                                      "and design, nothing simulated. docs/how-to/sensitivity.md.")
    sens.add_argument("source", nargs="?", type=Path, metavar="SOURCE",
                      help="a campaign store (.h5, with an answer) or a model file (YAML); default: the shipped model")
    sens.add_argument("--design", type=Path, metavar="FILE",
                      help="a design's features as benchmarks/diagnosis.py make-design writes them: use them, "
                           "simulate nothing (default for the shipped model: its shipped design)")
    sens.add_argument("--replicates", type=int, default=3, metavar="N",
                      help="replicates of the experiment the noise unit is for (default 3)")
    sens.add_argument("--workers", type=int, default=1, metavar="N", help="simulations at once (default 1)")
    sens.add_argument("-o", "--output", type=Path, metavar="DIR",
                      help="output folder (default: STORE.sensitivity/ or runs/sensitivity-MODEL/)")

    report = sub.add_parser("report", help="write an HTML report with figures of a campaign store",
                            description="The campaign's figures and tables: C–AIF cartography, yield loci, τ curves "
                                        "of the best point, surrogate maps with an identifiability statement, "
                                        "convergence, failures, and the diagnosis where there is one. By default a "
                                        "folder: index.html, summary.md and the figures as PNG and SVG files beside "
                                        "the page (share the folder, not the page alone). With --single-file, one "
                                        "HTML file with every figure embedded, to mail or attach: it opens with no "
                                        "other file beside it.")
    report.add_argument("store", type=Path, help="the campaign's HDF5 store")
    report.add_argument("--single-file", action="store_true",
                        help="write one HTML file with the figures embedded (default STORE.report.html)")
    report.add_argument("-o", "--output", type=Path, metavar="PATH",
                        help="output folder (default STORE.report/); with --single-file the file, or a folder "
                             "to write STORE.report.html into")

    sub.add_parser("plugins", help="list registered plugins and the broken ones",
                   description="Every plugin by kind, with its name, version and distribution; plugins that "
                               "failed to load are listed with their error.")
    return p


def _cmd_run(args: argparse.Namespace) -> int:
    from calibrax.core.studies.campaign import run_campaign
    from calibrax.core.config import load_config
    from calibrax.errors import ConfigError

    config = load_config(args.config)
    if args.workers is not None:
        if args.workers < 1:
            raise ConfigError("--workers", f"must be ≥ 1, got {args.workers}")
        config = dataclasses.replace(config, executor_options={**config.executor_options, "workers": args.workers})
    if args.check:
        _print_check(config)
        return 0
    if args.json:
        def emit(event: dict) -> None:
            print(json.dumps(event, default=float), flush=True)

        summary = run_campaign(config, emit)
        emit({"event": "summary", **dataclasses.asdict(summary), "store": str(summary.store)})
        return 0
    summary = run_campaign(config)
    print(f"campaign {config.name}: {summary.points} points, {summary.done} done, {summary.failed} failed; "
          f"store {summary.store}")
    if summary.answer is not None:
        from calibrax.core.search.answer import Answer

        print(f"answer: {Answer.from_dict(summary.answer).summary()}")
    if summary.best_id is not None:
        params = ", ".join(f"{k} = {v:.4g}" for k, v in summary.best_params.items())
        print(f"best observed (one draw of the noise, not the answer): point {summary.best_id}: {params}; "
              f"distance {summary.best_value:.3g} ± {summary.best_uncertainty:.2g}, {summary.noise_text()}")
    return 0


def _print_check(config) -> None:
    """``run --check``: the resolved settings, the cell, the experiment and the store, all checked as a
    run checks them; nothing is run or written."""
    from calibrax.core.running.store import CampaignStore

    exists = CampaignStore(config.store).check(config.search_hash(), config.store_mismatch)
    print(yaml.safe_dump(config.resolved, sort_keys=False, allow_unicode=True), end="")
    cells = [(f"{f.name} ({f.cost:g} CPU-s per simulation{', the target' if f is config.fidelities[-1] else ''})",
              f.spec) for f in config.fidelities] or [("", config.spec)]
    for name, spec in cells:
        print(f"# cell{' ' + name if name else ''}: {spec.cell_words()}, Δt = {spec.time_step:.3g} s "
              f"({spec.numerics.dt_fraction:g} × Δt_crit {spec.critical_time_step:.3g} s "
              f"at σ0 = {spec.numerics.stress_for_dt or spec.procedure.preshear_stress:g} Pa)")
    exp = config.experiment
    locus = exp.locus()
    print(f"# experiment {exp.name}: {len(exp.normal_stress)} points, {len(exp.replicates)} replicate(s), "
          f"C = {locus.cohesion:.0f} Pa, AIF = {locus.aif_deg:.1f}°")
    if config.executor == "dask" and config.executor_options.get("cluster") in ("slurm", "pbs"):
        from calibrax.core.registry import get_manager

        executor = get_manager().create("executor", "dask", **config.executor_options)
        print("# the job script dask-jobqueue will submit:")
        print("\n".join(f"#   {line}" for line in executor.job_script().splitlines()))
    if exists:
        print(f"# store {config.store}: made by this campaign; a run resumes it")
    else:
        folder = "" if config.store.parent.is_dir() else f" (and its folder {config.store.parent})"
        print(f"# store {config.store}: new; a run creates it{folder}")
    print("# OK: nothing was run or written")


def _cmd_status(args: argparse.Namespace) -> int:
    from calibrax.core.studies.campaign import Campaign
    from calibrax.core.running.store import CampaignStore
    from calibrax.core.search.records import Status

    store = CampaignStore(args.store)
    points = store.points()
    summary = Campaign.summary(store)
    if args.json:
        rows = [{"id": p.id, "batch": p.batch, "source": p.acquisition, "params": p.params(), "status": str(p.status),
                 "distance": None if p.metric is None else p.metric.value,
                 "uncertainty": None if p.metric is None else p.metric.uncertainty,
                 "features": {} if p.metric is None else p.metric.features,
                 "failures": [s.reason for s in p.sims if s.status == Status.FAILED]} for p in points]
        print(json.dumps({"points": rows, "best_id": summary.best_id, "answer": summary.answer}, default=float,
                         indent=1))
        return 0
    from calibrax.report.status import status_text

    print(status_text(store))
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from calibrax.core.running.store import CampaignStore
    from calibrax.report.trials import write_trials_csv

    store = CampaignStore(args.store)
    out = args.output or args.store.with_name(f"{args.store.stem}-trials.csv")
    print(f"written: {write_trials_csv(store, out)}")
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from calibrax.report import build_report, build_single_file_report

    page = (build_single_file_report if args.single_file else build_report)(args.store, args.output)
    print(f"report written: {page}")
    return 0


def _cmd_crosscheck(args: argparse.Namespace) -> int:
    from calibrax.studies_command import crosscheck_command

    return crosscheck_command(args)


def _cmd_converge(args: argparse.Namespace) -> int:
    from calibrax.studies_command import converge_command

    return converge_command(args)


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from calibrax.diagnosis.command import run_diagnose

    return run_diagnose(args.store, effects=args.effects, backend=args.backend, budget=args.budget,
                        fit_on=args.fit_on, seed=args.seed, output=args.output, workers=args.workers)


def _cmd_sensitivity(args: argparse.Namespace) -> int:
    from calibrax.diagnosis.sensitivity import run_sensitivity

    page = run_sensitivity(args.source, design=args.design, replicates=args.replicates, workers=args.workers,
                           output=args.output)
    print(f"{page.read_text(encoding='utf-8')}\nwritten: {page}, {page.with_suffix('.json')}, {page.with_suffix('.png')}")
    return 0


def _cmd_diagnose_benchmark(args: argparse.Namespace) -> int:
    from calibrax.diagnosis.benchmark.command import run_benchmark

    return run_benchmark(level=args.level, model=args.model, design=args.design, per_class=args.per_class,
                         cases=args.cases, labels=args.labels, answers=args.answers, also=args.also, seed=args.seed,
                         workers=args.workers, output=args.output)


def _cmd_plugins(args: argparse.Namespace) -> int:
    from calibrax.core.registry import HOOKS, get_manager

    manager = get_manager()
    print(f"{'kind':<12} {'name':<18} {'version':<10} distribution")
    for kind in HOOKS:
        if not manager.plugins(kind):
            print(f"{kind:<12} (none installed)")
        for name, info in sorted(manager.plugins(kind).items()):
            print(f"{kind:<12} {name:<18} {info.version:<10} {info.distribution}")
    if manager.broken:
        print("\nbroken (skipped):")
        for b in manager.broken:
            print(f"  {b.entry_point} from {b.distribution}: {b.error}")
    return 0


def _warning_to_log(message, category, *args: object, **kwargs: object) -> None:
    logging.getLogger("calibrax").warning("%s: %s", category.__name__, message)


def _raise_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``calibrax`` console script; returns the exit code."""
    from calibrax.errors import CalibraxError

    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    quiet = getattr(args, "quiet", False) or (args.command == "run" and args.json)
    logging.basicConfig(level=logging.WARNING if quiet else logging.INFO, stream=sys.stderr,
                        format="%(asctime)s %(levelname).1s %(message)s", datefmt="%H:%M:%S")
    logging.getLogger("matplotlib").setLevel(logging.WARNING)  # e.g. "generated new fontManager" on a fresh machine
    warnings.showwarning = _warning_to_log  # plugin warnings: one log line each, no source dump
    signal.signal(signal.SIGTERM, _raise_interrupt)
    handlers = {"run": _cmd_run, "status": _cmd_status, "export": _cmd_export, "report": _cmd_report,
                "crosscheck": _cmd_crosscheck, "converge": _cmd_converge, "diagnose": _cmd_diagnose,
                "diagnose-benchmark": _cmd_diagnose_benchmark, "sensitivity": _cmd_sensitivity, "plugins": _cmd_plugins}
    try:
        return handlers[args.command](args)
    except CalibraxError as exc:
        print(f"calibrax: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("calibrax: stopped; finished results are in the store — run the same command again to resume",
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
