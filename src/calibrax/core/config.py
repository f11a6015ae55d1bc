"""campaign.yaml → a validated, typed :class:`CampaignConfig`.

Every key is checked before anything runs: an unknown key, a wrong type, a non-finite number, a
bound with low ≥ high, a missing file or an unknown plugin name raises :class:`ConfigError`
naming the key path and what is allowed. Paths are relative to the campaign file's folder.
YAML is read with a ``yaml.SafeLoader`` that refuses duplicate keys and deep nesting
(:func:`calibrax.core.yamlfile.read_yaml`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from calibrax.core.data.experiment import Experiment, experiment_fingerprint, load_experiment
from calibrax.core.fidelities import (Fidelity, FidelityPlan, campaign_fidelities, check_multi_fidelity, fidelity_plan,
                                      is_multi_fidelity)
from calibrax.core.search.parameters import ParameterSpace
from calibrax.core.options import check_options
from calibrax.core.resolved import without_added_defaults
from calibrax.core.search.parameters import check_parameter_capabilities
from calibrax.core.sheartest.presets import FIDELITY_PRESETS, PROCEDURES
from calibrax.core.sheartest.spec import Geometry, Material, Numerics, Procedure, ShearCellSpec, SizeDistribution
from calibrax.core.yamlfile import read_yaml
from calibrax.errors import ConfigError, PluginError, SpecError

ROOT_KEYS = {
    "name": "a label for the campaign (text)",
    "description": "free text",
    "simulator": "the backend plugin (e.g. numba_dem, liggghts, yade)",
    "experiment": "a points CSV or an experiment YAML header",
    "cell": "{preset, procedure, geometry, numerics, size_distribution, fill_solid_fraction}",
    "material": "fixed material values (Material fields and radius)",
    "parameters": "{name: {low, high, log}} of the calibrated parameters",
    "metric": "a metric name or {name, options...}",
    "acquisition": "an acquisition name or {name, q, options...}",
    "budget": "{initial, iterations, patience}",
    "executor": "an executor name or {name, workers, timeout_s}",
    "store": "path of the campaign's HDF5 store",
    "workdir": "folder for the simulations' work folders (default: next to the store)",
    "seed": "integer seed of the search and of the simulations",
    "seeds_per_point": "simulations (different seeds) per parameter point",
    "surrogate": "{model: composite or distance, transform: log1p or identity, noise: metric or fitted}: the "
                 "Kriging model (transform and noise: the distance model's)",
    "enqueue": "a list of {parameter: value} points to simulate first, before the Sobol design",
    "warm_start": "an earlier campaign's store (same simulator, cell and parameters) whose finished "
                  "simulations a new store starts with",
    "fidelities": "a multi-fidelity campaign's presets, cheapest first, the target last: each a preset name or "
                  "{preset, cost, initial}",
}
#: the Kriging model's options and their defaults (calibrax.core.search.surrogate)
SURROGATE_DEFAULTS = {"model": "composite", "transform": "log1p", "noise": "metric"}
SURROGATE_CHOICES = {"model": ("distance", "composite"), "transform": ("log1p", "identity"),
                     "noise": ("metric", "fitted")}
REQUIRED = ("name", "simulator", "experiment", "parameters", "store")
CELL_KEYS = {"preset", "procedure", "geometry", "numerics", "size_distribution", "fill_solid_fraction"}


@dataclass(frozen=True)
class CampaignConfig:
    """A validated campaign. ``spec`` is the base spec: calibrated parameters replace its material
    values at each point, and ``numerics.seed`` is set per simulation."""

    name: str
    source: Path
    simulator: str
    experiment: Experiment
    spec: ShearCellSpec
    space: ParameterSpace
    metric: str
    metric_options: dict[str, Any]
    acquisition: str
    q: int
    batching: str
    acquisition_options: dict[str, Any]
    initial: int
    iterations: int
    executor: str
    executor_options: dict[str, Any]
    store: Path
    workdir: Path
    seed: int
    seeds_per_point: int
    resolved: dict[str, Any] = field(default_factory=dict)
    surrogate: dict[str, str] = field(default_factory=lambda: dict(SURROGATE_DEFAULTS))
    #: hand-chosen points (natural units), shape (k, dim), simulated first
    enqueue: tuple[tuple[float, ...], ...] = ()
    #: an earlier store whose finished simulations a new store starts with (None: none)
    warm_start: Path | None = None
    #: stop early once the answer has settled for this many successive batches (0: never)
    patience: int = 0
    #: a multi-fidelity campaign's fidelities, cheapest first, the target last (empty: one fidelity,
    #: ``spec``); ``spec`` is then the target's
    fidelities: tuple[Fidelity, ...] = ()

    @property
    def target_points(self) -> int:
        """Points the whole campaign simulates: the enqueued ones, the initial design (at every
        fidelity), the iterations."""
        return len(self.enqueue) + self.plan.initial_points(self.initial) + self.iterations * self.q

    @property
    def plan(self) -> FidelityPlan:
        """What the campaign's fidelities decide (:class:`~calibrax.core.fidelities.FidelityPlan`):
        one fidelity (``spec``) or several."""
        return fidelity_plan(self.fidelities, self.spec)

    def search_hash(self) -> str:
        """Hash of what defines the search (not budget, executor or paths; the experiment by its
        data, not its path): a store made with a different one cannot be resumed with this config."""
        return search_identity(self.resolved, self.experiment)

    def store_mismatch(self, stored_config: dict[str, Any], stored_experiment: Experiment | None) -> str | None:
        """Why a store made with ``stored_config`` (its resolved config) and ``stored_experiment``
        (the experiment's data it keeps) cannot be resumed with this config, or None if it can. A
        store written before the search hash ignored the experiment's path carries that older hash;
        this compares what defines the search instead, so it resumes from any folder."""
        made = search_identity(stored_config, stored_experiment)
        if made == self.search_hash():
            return None
        if search_identity(stored_config, self.experiment) == self.search_hash():
            return (f"the experiment's data ({self.resolved['experiment']}) are not those the store was made "
                    "with: the experiment file has changed")
        return f"search hash {made} ≠ {self.search_hash()}"


#: the largest relative difference between the experiment's and the cell's preshear stress
PRESHEAR_TOLERANCE = 0.05


def _check_same_preshear(experiment: Experiment, path: Path, spec: ShearCellSpec) -> None:
    """An experiment preshear at one stress (``preshear_stress_pa``) calibrates a cell that
    preshears at the same: a 3 kPa test against the 15 kPa procedure compares two different loci."""
    measured, simulated = float(experiment.preshear_stress), spec.procedure.preshear_stress
    if math.isfinite(measured) and not math.isclose(measured, simulated, rel_tol=PRESHEAR_TOLERANCE):
        same = [name for name, p in PROCEDURES.items()
                if math.isclose(p["preshear_stress"], measured, rel_tol=PRESHEAR_TOLERANCE)]
        hint = f"; the preset {same[0]!r} preshears at {measured / 1e3:g} kPa" if same else ""
        raise ConfigError("cell.procedure", f"the experiment {path.name} was presheared at {measured / 1e3:g} kPa "
                          f"(preshear_stress_pa), the cell preshears at {simulated / 1e3:g} kPa; set the cell's "
                          f"procedure to the test that was measured{hint}")


def search_identity(resolved: dict[str, Any], experiment: Experiment | None) -> str:
    """Hash of what defines a search: the resolved config without budget, executor, paths, names,
    the surrogate's options, the enqueued or warm-start points (stored points are data whatever
    proposed them) and the cheaper fidelities' cells (made from ``cell`` and ``fidelities``, which
    the hash holds; recorded for ``calibrax diagnose``), and the experiment by its data (:func:`~calibrax.core.data.experiment.experiment_fingerprint`)."""
    keep = {k: v for k, v in resolved.items() if k not in ("budget", "executor", "store", "workdir", "description",
                                                           "name", "surrogate", "enqueue", "warm_start", "experiment",
                                                           "fidelity_cells")}
    keep = without_added_defaults(keep)
    keep["experiment_data"] = experiment_fingerprint(experiment) if experiment is not None else None
    return hashlib.sha256(json.dumps(keep, sort_keys=True).encode()).hexdigest()[:16]


# ----------------------------------------------------------------------------- small checkers
def _number(key: str, v: Any, *, positive: bool = False, allow_none: bool = False) -> float | None:
    if v is None and allow_none:
        return None
    if isinstance(v, str):  # PyYAML reads 5.0e9 (no sign in the exponent) as text: accept numeric text
        try:
            v = float(v)
        except ValueError:
            raise ConfigError(key, f"must be a number, got str {v!r}") from None
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(key, f"must be a number, got {type(v).__name__} {v!r}")
    if not math.isfinite(v):
        raise ConfigError(key, f"must be a finite number, got {v!r}")
    if positive and v <= 0:
        raise ConfigError(key, f"must be > 0, got {v!r}")
    return float(v)


def _integer(key: str, v: Any, minimum: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise ConfigError(key, f"must be an integer ≥ {minimum}, got {type(v).__name__} {v!r}")
    if v < minimum:
        raise ConfigError(key, f"must be an integer ≥ {minimum}, got {v}")
    return v


def _text(key: str, v: Any) -> str:
    if not isinstance(v, str) or not v.strip():
        raise ConfigError(key, f"must be non-empty text, got {type(v).__name__} {v!r}")
    return v


def _mapping(key: str, v: Any, allowed: set[str] | dict) -> dict:
    if not isinstance(v, dict):
        raise ConfigError(key, f"must be a mapping with keys from {sorted(allowed)}, got {type(v).__name__}")
    for k in v:
        if not isinstance(k, str) or k not in allowed:
            raise ConfigError(f"{key}.{k}", f"unknown key; allowed: {sorted(allowed)}")
    return v


def _dataclass_values(key: str, raw: Any, cls: type) -> dict[str, Any]:
    """Check a mapping against a dataclass's fields by their annotations (float, int, bool, str,
    ``float | None``, ``tuple[float, ...]``); return the converted values."""
    fields_ = {f.name: str(f.type) for f in dataclasses.fields(cls)}
    _mapping(key, raw, fields_)
    out: dict[str, Any] = {}
    for name, value in raw.items():
        k, typ = f"{key}.{name}", fields_[name]
        if typ.startswith("tuple"):
            if not isinstance(value, list) or not value:
                raise ConfigError(k, f"must be a non-empty list of numbers, got {value!r}")
            out[name] = tuple(_number(f"{k}[{i}]", x) for i, x in enumerate(value))
        elif typ == "int":
            out[name] = _integer(k, value, 0)
        elif typ == "float | None":
            out[name] = _number(k, value, allow_none=True)
        elif typ == "float":
            out[name] = _number(k, value)
        elif typ == "bool":
            if not isinstance(value, bool):
                raise ConfigError(k, f"must be true or false, got {type(value).__name__} {value!r}")
            out[name] = value
        else:
            out[name] = _text(k, value)
    return out


def _named(key: str, raw: Any, kind: str, default: str | None = None) -> tuple[str, dict[str, Any]]:
    """``name`` or ``{name: ..., option: ...}`` → (name, options), the name checked against the plugins."""
    from calibrax.core.registry import get_manager

    if raw is None and default is not None:
        raw = default
    if isinstance(raw, str):
        name, options = raw, {}
    elif isinstance(raw, dict):
        if "name" not in raw:
            raise ConfigError(f"{key}.name", "is required")
        name, options = raw["name"], {k: v for k, v in raw.items() if k != "name"}
        if not isinstance(name, str):
            raise ConfigError(f"{key}.name", f"must be text, got {name!r}")
    else:
        raise ConfigError(key, f"must be a {kind} name or a mapping with 'name', got {type(raw).__name__}")
    try:
        info = get_manager().get(kind, name)
    except PluginError as exc:
        raise ConfigError(key, str(exc)) from None
    return name, check_options(key, info.cls, options)


def _enqueued(raw: Any, space: ParameterSpace) -> tuple[tuple[float, ...], ...]:
    """``enqueue``: a list of {name: value} points inside the box, every parameter given."""
    if not isinstance(raw, list):
        raise ConfigError("enqueue", f"must be a list of {{parameter: value}} points, got {type(raw).__name__}")
    rows = []
    for i, point in enumerate(raw):
        point = _mapping(f"enqueue[{i}]", point, set(space.names))
        row = []
        for p in space.parameters:
            if p.name not in point:
                raise ConfigError(f"enqueue[{i}].{p.name}", f"is required: every calibrated parameter "
                                  f"({', '.join(space.names)}) needs a value")
            v = _number(f"enqueue[{i}].{p.name}", point[p.name])
            if not p.low <= v <= p.high:
                raise ConfigError(f"enqueue[{i}].{p.name}", f"must lie in the searched range [{p.low:g}, {p.high:g}], "
                                  f"got {v:g}")
            row.append(float(v))
        rows.append(tuple(row))
    return tuple(rows)


# ----------------------------------------------------------------------------- the spec
def build_spec(cell: Any, material: Any) -> ShearCellSpec:
    """The base spec from ``cell:`` and ``material:`` (both optional)."""
    cell = _mapping("cell", {} if cell is None else cell, CELL_KEYS)
    material = {} if material is None else material
    mat_fields = {f.name for f in dataclasses.fields(Material)} | {"radius"}
    _mapping("material", material, mat_fields)
    preset = cell.get("preset", "quick")
    if not isinstance(preset, str) or preset not in FIDELITY_PRESETS:
        raise ConfigError("cell.preset", f"unknown preset {preset!r}; allowed: {sorted(FIDELITY_PRESETS)}")
    procedure = cell.get("procedure", "paper")
    proc_overrides: dict[str, Any] = {}
    if isinstance(procedure, dict):
        proc_fields = {f.name for f in dataclasses.fields(Procedure)} | {"preset"}
        _mapping("cell.procedure", procedure, proc_fields)
        proc_overrides = _dataclass_values("cell.procedure", {k: v for k, v in procedure.items() if k != "preset"},
                                           Procedure)
        procedure = procedure.get("preset", "paper")
    if not isinstance(procedure, str) or procedure not in PROCEDURES:
        raise ConfigError("cell.procedure", f"unknown procedure {procedure!r}; allowed: {sorted(PROCEDURES)} "
                          "or a mapping of procedure fields")
    mat_values = _dataclass_values("material", {k: v for k, v in material.items() if k != "radius"}, Material)
    overrides: dict[str, Any] = {"material": mat_values}
    if "radius" in material:
        overrides["radius"] = _number("material.radius", material["radius"], positive=True)
    for sub, cls in (("geometry", Geometry), ("numerics", Numerics), ("size_distribution", SizeDistribution)):
        if sub in cell:
            overrides[sub] = _dataclass_values(f"cell.{sub}", cell[sub], cls)
    if "fill_solid_fraction" in cell:
        overrides["fill_solid_fraction"] = _number("cell.fill_solid_fraction", cell["fill_solid_fraction"])
    try:
        spec = ShearCellSpec.preset(preset, procedure, **overrides)
        if proc_overrides:
            spec = spec.replace(procedure=proc_overrides)
        spec.validate()
    except SpecError as exc:
        where = exc.key if exc.key.startswith(("material.", "cell.")) else (
            "material.radius" if exc.key == "radius" else f"cell.{exc.key}")
        raise ConfigError(where, exc.message) from None
    except TypeError as exc:
        raise ConfigError("cell", str(exc)) from None
    return spec


# ----------------------------------------------------------------------------- the campaign
def load_config(path: str | Path) -> CampaignConfig:
    """Read and validate a campaign file (nothing is written)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(str(path), "campaign file not found")
    return parse_config(read_yaml(path), base=path.parent, source=path)


def parse_config(raw: Any, base: Path, source: Path | None = None) -> CampaignConfig:
    """Validate an already-parsed mapping; relative paths are taken from ``base``. One parser per
    section, called in the order their errors are reported."""
    _check_keys(raw)
    name = _text("name", raw["name"])
    _check_description(raw)
    simulator = _simulator(raw["simulator"])
    exp_path, experiment = _experiment(raw["experiment"], base)
    budget = _mapping("budget", raw.get("budget", {}), {"initial", "iterations", "patience"})
    initial = _integer("budget.initial", budget.get("initial", 4), 2)
    fidelities = campaign_fidelities(raw, initial, build_spec)
    spec = fidelities[-1].spec if fidelities else build_spec(raw.get("cell"), raw.get("material"))
    _check_same_preshear(experiment, exp_path, spec)
    space = ParameterSpace.from_config(raw["parameters"])
    metric, metric_options = _named("metric", raw.get("metric"), "metric", default="c_aif")
    acquisition, q, batching, acq_options = _acquisition(raw.get("acquisition"), bool(fidelities))
    iterations = _integer("budget.iterations", budget.get("iterations", 8), 0)
    patience = _integer("budget.patience", budget.get("patience", 0), 0)
    executor, exec_options = _executor(raw.get("executor"))
    store = _store(raw["store"], base)
    workdir = base / _text("workdir", raw["workdir"]) if "workdir" in raw else store.with_suffix(".runs")
    seed = _integer("seed", raw.get("seed", 0), 0)
    seeds_per_point = _integer("seeds_per_point", raw.get("seeds_per_point", 1), 1)
    surrogate = _surrogate(raw.get("surrogate", {}))
    enqueue = _enqueued(raw.get("enqueue", []), space)
    warm_start = base / _text("warm_start", raw["warm_start"]) if "warm_start" in raw else None
    _check_fidelities(raw, fidelities, acquisition, warm_start, surrogate)
    _check_plugins(raw, simulator, spec, space, experiment, (metric, metric_options), (acquisition, acq_options),
                   (executor, exec_options))
    resolved = {
        "name": name, "simulator": simulator, "experiment": str(exp_path), "cell": spec.to_dict(),
        "parameters": {p.name: {"low": p.low, "high": p.high, "log": p.log} for p in space.parameters},
        "metric": {"name": metric, **metric_options},
        "acquisition": {"name": acquisition, "q": q, "batching": batching, **acq_options},
        "budget": {"initial": initial, "iterations": iterations, **({"patience": patience} if patience else {})},
        "executor": {"name": executor, **exec_options}, "store": str(store), "workdir": str(workdir),
        "seed": seed, "seeds_per_point": seeds_per_point, "surrogate": surrogate,
        **({"enqueue": [list(row) for row in enqueue]} if enqueue else {}),
        **({"warm_start": str(warm_start)} if warm_start else {}),
        **({"fidelities": [f.to_dict() for f in fidelities],
            "fidelity_cells": {f.name: f.spec.to_dict() for f in fidelities[:-1]}} if fidelities else {}),
    }
    if warm_start is not None:
        from calibrax.core.warm_start import check_warm_start

        check_warm_start(warm_start, resolved, space)
    return CampaignConfig(name, source or base, simulator, experiment, spec, space, metric, metric_options,
                          acquisition, q, batching, acq_options, initial, iterations, executor, exec_options, store,
                          workdir, seed, seeds_per_point, resolved, surrogate, enqueue, warm_start, patience,
                          fidelities)


# ----------------------------------------------------------------------------- one parser per section
def _check_keys(raw: Any) -> None:
    """A mapping of the known keys, the required ones given."""
    if not isinstance(raw, dict):
        raise ConfigError("", f"a campaign file must be a mapping of keys {sorted(ROOT_KEYS)}")
    for key in raw:
        if not isinstance(key, str) or key not in ROOT_KEYS:
            allowed = ", ".join(f"{k} ({v})" for k, v in ROOT_KEYS.items())
            raise ConfigError(str(key), f"unknown key; allowed: {allowed}")
    for key in REQUIRED:
        if key not in raw:
            raise ConfigError(key, f"is required: {ROOT_KEYS[key]}")


def _check_description(raw: dict) -> None:
    if "description" in raw and not isinstance(raw["description"], str):
        # free text: a list or a number is a mistake, not something to drop without a word
        raise ConfigError("description", f"must be text, got {type(raw['description']).__name__} "
                                         f"{raw['description']!r}")


def _simulator(raw: Any) -> str:
    """``simulator``: a plugin's name, no options."""
    simulator, sim_options = _named("simulator", raw, "simulator")
    if sim_options:
        raise ConfigError(f"simulator.{sorted(sim_options)[0]}", "simulators take no options here; "
                          "set threads under cell.numerics.threads")
    return simulator


def _experiment(raw: Any, base: Path) -> tuple[Path, Experiment]:
    """``experiment``: the path (from ``base``) and the experiment read from it."""
    exp_path = base / _text("experiment", raw)
    try:
        return exp_path, load_experiment(exp_path)
    except ConfigError as exc:
        raise ConfigError("experiment", str(exc)) from None


def _acquisition(acq_raw: Any, multi_fidelity: bool) -> tuple[str, int, str, dict[str, Any]]:
    """``acquisition``: its name, ``q``, ``batching`` and the plugin's options (default qei, or
    mfei with fidelities)."""
    q, batching = 2, "sync"
    if isinstance(acq_raw, dict):
        if "q" in acq_raw:
            q = _integer("acquisition.q", acq_raw["q"], 1)
        if "batching" in acq_raw:
            batching = acq_raw["batching"]
            if batching not in ("sync", "async"):
                raise ConfigError("acquisition.batching", f"must be 'sync' (the paper's: a whole batch, then the "
                                  f"next) or 'async' (a new point as soon as a worker frees up), got {batching!r}")
        acq_raw = {k: v for k, v in acq_raw.items() if k not in ("q", "batching")}
    acquisition, acq_options = _named("acquisition", acq_raw, "acquisition",
                                      default="mfei" if multi_fidelity else "qei")
    return acquisition, q, batching, acq_options


def _executor(raw: Any) -> tuple[str, dict[str, Any]]:
    """``executor``: its name (default local) and options, ``workers`` ≥ 1 and ``timeout_s`` > 0."""
    executor, exec_options = _named("executor", raw, "executor", default="local")
    workers = exec_options.get("workers")
    if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool) or workers < 1):
        raise ConfigError("executor.workers", f"must be an integer ≥ 1, got {workers!r}")
    timeout = exec_options.get("timeout_s")
    if timeout is not None and (not isinstance(timeout, (int, float)) or isinstance(timeout, bool) or timeout <= 0):
        raise ConfigError("executor.timeout_s", f"must be a number > 0 s, got {timeout!r}")
    return executor, exec_options


def _store(raw: Any, base: Path) -> Path:
    """``store``: an HDF5 file's path (from ``base``), not a folder."""
    store = base / _text("store", raw)
    if store.suffix not in (".h5", ".hdf5"):
        raise ConfigError("store", f"must name an HDF5 file ending in .h5 or .hdf5, got {store.name!r}")
    if store.exists() and not store.is_file():
        raise ConfigError("store", f"{store} exists and is not a file")
    return store


def _surrogate(raw: Any) -> dict[str, str]:
    """``surrogate``: :data:`SURROGATE_DEFAULTS` with the options given, each one of its
    :data:`SURROGATE_CHOICES`."""
    surrogate = dict(SURROGATE_DEFAULTS)
    for key, value in _mapping("surrogate", raw, set(SURROGATE_DEFAULTS)).items():
        if value not in SURROGATE_CHOICES[key]:
            raise ConfigError(f"surrogate.{key}", f"must be one of {list(SURROGATE_CHOICES[key])}, got {value!r}")
        surrogate[key] = value
    return surrogate


def _check_fidelities(raw: dict, fidelities: tuple[Fidelity, ...], acquisition: str, warm_start: Path | None,
                      surrogate: dict[str, str]) -> None:
    """A multi-fidelity acquisition with fidelities, and only with them; ``mfkg`` sets the
    surrogate's model to ``distance`` (BoTorch's knowledge gradient needs one GP of the distance
    over (x, fidelity))."""
    if fidelities:
        check_multi_fidelity(raw, acquisition, warm_start)
        if acquisition == "mfkg":
            surrogate["model"] = "distance"
    elif is_multi_fidelity(acquisition):
        raise ConfigError("acquisition", f"{acquisition!r} chooses among fidelities; name them under fidelities "
                          "(e.g. [tiny, quick]), or use a one-fidelity acquisition such as qei")


def _check_plugins(raw: dict, simulator: str, spec: ShearCellSpec, space: ParameterSpace, experiment: Experiment,
                   metric: tuple[str, dict[str, Any]], acquisition: tuple[str, dict[str, Any]],
                   executor: tuple[str, dict[str, Any]]) -> None:
    """Build the plugins once so their own option checks run now, not mid-campaign: the metric,
    acquisition and executor with their options ((name, options) each), the metric's scales on the
    experiment, the composite model's need of a metric that states its terms, the simulator's
    capabilities for the spec and for every calibrated field."""
    from calibrax.core.search.metric import TermsMetric
    from calibrax.core.registry import get_manager
    from calibrax.core.simulator import check_capabilities

    manager = get_manager()
    for kind, (pname, opts) in (("metric", metric), ("acquisition", acquisition), ("executor", executor)):
        try:
            manager.create(kind, pname, **opts)
        except TypeError as exc:
            raise ConfigError(kind, str(exc)) from None
    try:
        metric_obj = manager.create("metric", metric[0], **metric[1])
        metric_obj.scales(experiment) if hasattr(metric_obj, "scales") else None
        asked = isinstance(raw.get("surrogate"), dict) and raw["surrogate"].get("model") == "composite"
        if asked and not isinstance(metric_obj, TermsMetric):  # by default: the distance model stands in
            raise ConfigError("surrogate.model", f"composite needs a metric that states its distance's terms "
                              f"(calibrax.core.search.metric.TermsMetric); metric {metric[0]!r} does not: use model: "
                              "distance, or the metric c_aif or robust")
        simulator_obj = manager.create("simulator", simulator)
        check_capabilities(simulator_obj, spec)
        check_parameter_capabilities(simulator_obj, space)
    except PluginError as exc:
        raise ConfigError("simulator", str(exc)) from None
    if executor[0] != "dask" and hasattr(simulator_obj, "check_machine"):
        # the simulations run on this machine: a backend may refuse what it cannot run here (a
        # GPU asked for, none visible); a Dask executor's workers are elsewhere and check it themselves
        try:
            simulator_obj.check_machine(spec)
        except ConfigError as exc:
            raise ConfigError(f"cell.{exc.key}", exc.message) from None
