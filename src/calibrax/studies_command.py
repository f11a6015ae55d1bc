"""The bodies of ``calibrax crosscheck`` and ``calibrax converge`` (the command line's parsers are
in :mod:`calibrax.cli`): a campaign's spec run at several backends or fidelity settings through its
executor, resumable, and the tables and figures written."""

from __future__ import annotations

import argparse
import concurrent.futures
import dataclasses
import json


def _study_config(args: argparse.Namespace, kind: str):
    """The campaign config and the output folder of a study (nothing is created yet)."""
    from calibrax.core.config import load_config
    from calibrax.errors import ConfigError

    config = load_config(args.config)
    if args.seeds < 1:
        raise ConfigError("--seeds", f"must be ≥ 1, got {args.seeds}")
    if args.workers is not None and args.workers < 1:
        raise ConfigError("--workers", f"must be ≥ 1, got {args.workers}")
    return config, args.output or config.store.with_suffix(f".{kind}")


def _study_executor(args: argparse.Namespace, config):
    """The campaign's executor, ``--workers`` overriding its ``workers``."""
    from calibrax.core.registry import get_manager

    options = dict(config.executor_options)
    if args.workers is not None:
        options["workers"] = args.workers
    return get_manager().create("executor", config.executor, **options)


def crosscheck_command(args: argparse.Namespace) -> int:
    """``calibrax crosscheck``: every input checked, the shear tests and the micro checks run, the page written."""
    from calibrax.core.studies.crosscheck import (agreements, crosscheck_cases, known_differences, micro_agreement,
                                          micro_checks, micro_material, parse_point)
    from calibrax.core.studies.study import run_study
    from calibrax.errors import ConfigError
    from calibrax.report.studies import crosscheck_figure, crosscheck_markdown

    backends = [b.strip() for b in args.backends.split(",") if b.strip()]
    if not backends:
        raise ConfigError("--backends",
                          f"give at least one simulator, e.g. numba_dem,liggghts,yade; got {args.backends!r}")
    if len(set(backends)) != len(backends):
        raise ConfigError("--backends", f"each backend once, got {args.backends!r}")
    config, out = _study_config(args, "crosscheck")
    # every input is checked before anything runs or is written
    cases = crosscheck_cases(config, backends, args.seeds, [parse_point(p, config) for p in args.points])
    executor = _study_executor(args, config)
    out.mkdir(parents=True, exist_ok=True)
    checks: dict = {}
    known: dict = {}
    # the micro-level checks (seconds per case, one backend after the other) run here while the
    # executor runs the shear tests
    with concurrent.futures.ThreadPoolExecutor(max_workers=1) as pool:
        micro = None if args.no_micro else pool.submit(micro_checks, config, backends)
        outcomes = run_study(cases, out / "crosscheck.h5", executor, config.workdir, "crosscheck")
        if micro is not None:
            checks = micro.result()
    if not args.no_micro:
        known = known_differences(backends)
        (out / "crosscheck-micro.json").write_text(json.dumps(
            {"material": dataclasses.asdict(micro_material(config)), "checks": checks,
             "known_differences": {b: {f"{f}.{q}": why for (f, q), why in k.items()} for b, k in known.items()}},
            indent=1, default=float), encoding="utf-8")
    micro = micro_agreement(checks, known)
    text = crosscheck_markdown(outcomes, agreements(outcomes), micro, checks, known,
                               None if args.no_micro else dataclasses.asdict(micro_material(config)))
    (out / "crosscheck.md").write_text(text, encoding="utf-8")
    crosscheck_figure(outcomes, out)
    print(text)
    written = [out / "crosscheck.md", out / "crosscheck.png", out / "crosscheck.svg", out / "crosscheck.h5"]
    if not args.no_micro:
        written.append(out / "crosscheck-micro.json")
    print("written: " + ", ".join(str(p) for p in written))
    return 0


def converge_command(args: argparse.Namespace) -> int:
    """``calibrax converge``: every input checked, the settings run, the verdicts and the page written."""
    from calibrax.core.studies.convergence import converge_cases, verdicts
    from calibrax.core.studies.study import run_study
    from calibrax.errors import ConfigError, PluginError
    from calibrax.core.registry import get_manager
    from calibrax.report.studies import converge_figure, converge_markdown

    settings = {}
    for option, knob in (("particles_per_diameter", "particles_per_diameter"), ("dt_fraction", "dt_fraction"),
                         ("shear_rate", "rotation_rate"), ("inertial_number", "inertial_number")):
        raw = getattr(args, option)
        if raw is not None:
            try:
                settings[knob] = [float(v) for v in raw.split(",") if v.strip()]
            except ValueError:
                raise ConfigError(f"--{option.replace('_', '-')}",
                                  f"must be comma-separated numbers, got {raw!r}") from None
    if not settings:
        raise ConfigError("converge", "give at least one fidelity knob: --particles-per-diameter, --dt-fraction "
                                      "or --shear-rate, each with two or more comma-separated values")
    config, out = _study_config(args, "converge")
    backend = args.backend or config.simulator
    if args.backend is not None:
        from calibrax.core.simulator import check_capabilities

        try:
            check_capabilities(get_manager().create("simulator", backend), config.spec)
        except (PluginError, ConfigError) as exc:
            raise ConfigError("--backend", getattr(exc, "message", str(exc))) from None
    cases = converge_cases(config, backend, args.seeds, settings)
    executor = _study_executor(args, config)
    out.mkdir(parents=True, exist_ok=True)
    outcomes = run_study(cases, out / "converge.h5", executor, config.workdir, "converge")
    results = verdicts(outcomes)
    text = converge_markdown(outcomes, results)
    (out / "converge.md").write_text(text, encoding="utf-8")
    converge_figure(outcomes, results, out)
    print(text)
    print(f"written: {out / 'converge.md'}, {out / 'converge.png'}, {out / 'converge.svg'}, {out / 'converge.h5'}")
    return 0


__all__ = ["crosscheck_command", "converge_command"]
