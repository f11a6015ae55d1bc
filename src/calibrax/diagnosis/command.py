"""``calibrax diagnose``: check every input, run the diagnosis, write its summary and figures."""

from __future__ import annotations

from pathlib import Path

from calibrax.errors import ConfigError, PluginError

#: the smallest budget that fits a design and a confirmation for one effect
MIN_BUDGET = 16


def run_diagnose(store: Path, *, effects: str | None = None, backend: str | None = None, budget: int | None = None,
                 fit_on: str = "locus,density", seed: int = 0, output: Path | None = None, workers: int | None = None) -> int:
    """The command's body; every input is checked before anything runs or is written."""
    from calibrax.diagnosis import Budget, Calibrated, diagnose, effects_by_name
    from calibrax.diagnosis.design import TARGET_RUNS
    from calibrax.diagnosis.report import write_diagnosis_report
    from calibrax.core.registry import get_manager

    from calibrax.diagnosis.gap import parse_groups

    fit_groups = parse_groups(fit_on)
    calibrated = Calibrated.from_store(store)
    names = [n.strip() for n in effects.split(",") if n.strip()] if effects is not None else None
    candidates = effects_by_name(names)
    backend = backend or calibrated.simulator
    try:
        simulator = get_manager().create("simulator", backend)
    except PluginError as exc:
        raise ConfigError("--backend", str(exc)) from None
    capabilities = frozenset(simulator.capabilities())
    if workers is not None and workers < 1:
        raise ConfigError("--workers", f"must be ≥ 1, got {workers}")
    if budget is not None and budget < MIN_BUDGET:
        raise ConfigError("--budget", f"must be ≥ {MIN_BUDGET} simulations, got {budget}")
    # the effects' split needs the usable effects: count them as diagnose() will
    usable = [e for e in candidates if e.capability in capabilities]
    # across fidelities a few replicates and the confirmations run at the target, the rest at the cheap level
    target_runs = TARGET_RUNS if calibrated.cheap else 0
    default = Budget.across_fidelities() if calibrated.cheap else Budget()
    plan = Budget.for_total(budget, max(len(usable), 1), target_runs) if budget is not None else default
    if budget is not None and plan.per_effect < 4:
        raise ConfigError("--budget", f"{budget} simulations leave {plan.per_effect} per effect for "
                                      f"{len(usable)} effects; give at least {plan.total(len(usable)) - plan.per_effect * len(usable) + 4 * len(usable)}")
    out = Path(output) if output is not None else Path(store).with_suffix(".diagnosis")
    cfg_executor = _executor_settings(Path(store))
    options = dict(cfg_executor[1])
    if workers is not None:
        options["workers"] = workers
    if cfg_executor[0] != "dask" and hasattr(simulator, "check_machine"):
        # the simulations run here: refuse a cell this machine cannot run (a GPU asked for, none here)
        for spec in (calibrated.spec, *([calibrated.cheap[1]] if calibrated.cheap else [])):
            try:
                simulator.check_machine(spec)
            except ConfigError as exc:
                raise ConfigError(f"cell.{exc.key}", f"{exc.message} (the store's campaign cell)") from None
    executor = get_manager().create("executor", cfg_executor[0], **options)
    result = diagnose(calibrated, candidates, out, executor, backend=backend, budget=plan, fit_on=fit_groups,
                      seed=seed, asked=names is not None, capabilities=capabilities)
    text, files = write_diagnosis_report(result, calibrated, out)
    print(text)
    print("written: " + ", ".join(str(out / f) for f in ["diagnosis.md", "diagnosis.json", *files]))
    return 0


def _executor_settings(store: Path) -> tuple[str, dict]:
    from calibrax.core.running.store import CampaignStore

    cfg = CampaignStore(store).config().get("executor") or {"name": "local", "workers": 1}
    return cfg.get("name", "local"), {k: v for k, v in cfg.items() if k != "name"}
