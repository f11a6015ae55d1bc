"""The calibrated model a diagnosis benchmark diagnoses its cases against, read from YAML.

Every case of a benchmark is diagnosed from the same calibrated model (backend, cell, material,
calibrated parameters with a "campaign answer" and its plausible region, candidate effects and
budget), so the diagnosis's DEM design is the same for all of them and runs once. The shipped
one is ``data/tiny.yaml``; a user's external cases name their own (``--model``)::

    simulator: numba_dem
    cell: {preset: tiny, procedure: paper}
    material: {rolling_friction: 0.5, radius: 0.9e-3}
    parameters:
      youngs_modulus: {low: 5.0e9, high: 5.0e10, log: true}
      sliding_friction: {low: 0.1, high: 0.9}
    centre: {youngs_modulus: 2.0e+10, sliding_friction: 0.35}       # the campaign's answer
    plausible: {youngs_modulus: [1.0e+10, 4.0e+10], sliding_friction: [0.2, 0.5]}   # optional
    effects: [wall_friction, size_distribution, cohesion]          # the candidate list
    budget: {replicates: 4, baseline: 8, per_effect: 10, confirm: 4}
    seed: 0
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from calibrax.core.search.parameters import ParameterSpace
from calibrax.core.sheartest import ShearCellSpec
from calibrax.diagnosis.design import Box, Budget, DesignPoint, design_points
from calibrax.diagnosis.effects import Effect
from calibrax.errors import ConfigError

#: the shipped model: numba_dem at ``tiny`` with the quickstart's material
DEFAULT_MODEL = Path(__file__).parent / "data" / "tiny.yaml"
MODEL_KEYS = {"simulator", "cell", "material", "parameters", "centre", "plausible", "effects", "budget", "seed"}


@dataclass(frozen=True)
class BenchmarkModel:
    """The calibrated model of a benchmark (see the module docstring); ``source`` is its file."""

    simulator: str
    spec: ShearCellSpec
    space: ParameterSpace
    centre: dict[str, float]
    plausible: dict[str, tuple[float, float]]
    effect_names: tuple[str, ...]
    budget: Budget
    seed: int
    source: Path

    @classmethod
    def load(cls, path: Path | None = None) -> "BenchmarkModel":
        """Read and check a model file (the shipped one for None); errors name the file and key."""
        from calibrax.core.config import build_spec
        from calibrax.core.yamlfile import read_yaml
        from calibrax.diagnosis import effects_by_name

        path = Path(path) if path is not None else DEFAULT_MODEL
        if not path.is_file():
            raise ConfigError("--model", f"{path}: no such model file (see calibrax.diagnosis.benchmark.model)")
        raw = read_yaml(path)
        if not isinstance(raw, dict):
            raise ConfigError(str(path), "must be a mapping with keys " + ", ".join(sorted(MODEL_KEYS)))
        unknown = sorted(set(raw) - MODEL_KEYS)
        if unknown:
            raise ConfigError(f"{path}: {unknown[0]}", f"unknown key; allowed: {sorted(MODEL_KEYS)}")
        for key in ("simulator", "parameters", "centre"):
            if key not in raw:
                raise ConfigError(f"{path}: {key}", "is required")
        space = ParameterSpace.from_config(raw["parameters"], key=f"{path}: parameters")
        centre = _values(path, "centre", raw["centre"], space, single=True)
        plausible = _values(path, "plausible", raw.get("plausible") or {}, space, single=False)
        names = raw.get("effects")
        if names is not None and (not isinstance(names, list) or not all(isinstance(n, str) for n in names)):
            raise ConfigError(f"{path}: effects", f"a list of effect names, got {names!r}")
        try:
            effects = effects_by_name(names)
        except ConfigError as exc:
            raise ConfigError(f"{path}: effects", exc.message) from None
        budget_raw = raw.get("budget") or {}
        allowed = {"replicates", "baseline", "per_effect", "confirm"}
        if not isinstance(budget_raw, dict) or set(budget_raw) - allowed or not all(
                isinstance(v, int) and v >= 0 for v in budget_raw.values()):
            raise ConfigError(f"{path}: budget", f"a mapping of {sorted(allowed)} to counts ≥ 0, got {budget_raw!r}")
        budget = Budget(**budget_raw)
        if budget.per_effect < 4 or budget.replicates < 2:
            raise ConfigError(f"{path}: budget", "needs per_effect ≥ 4 and replicates ≥ 2")
        seed = raw.get("seed", 0)
        if not isinstance(seed, int) or seed < 0:
            raise ConfigError(f"{path}: seed", f"an integer ≥ 0, got {seed!r}")
        spec = build_spec(raw.get("cell"), raw.get("material"))
        return cls(str(raw["simulator"]), spec, space, centre, plausible, tuple(e.name for e in effects), budget,
                   seed, path)

    @classmethod
    def from_store(cls, path: Path) -> "BenchmarkModel":
        """The calibrated model of a campaign store: its backend, cell, parameters and answer (the
        point and its plausible region), every effect the backend can model, the default budget."""
        from calibrax.core.registry import get_manager
        from calibrax.diagnosis import Calibrated, effects_by_name

        calibrated = Calibrated.from_store(path)
        capabilities = get_manager().create("simulator", calibrated.simulator).capabilities()
        names = tuple(e.name for e in effects_by_name(None) if e.capability in capabilities)
        return cls(calibrated.simulator, calibrated.spec, calibrated.space, dict(calibrated.centre),
                   dict(calibrated.plausible), names, Budget(), 0, Path(path))

    def effects(self) -> list[Effect]:
        from calibrax.diagnosis import effects_by_name

        return effects_by_name(list(self.effect_names))

    def effects_all(self) -> list[Effect]:
        """Every registered effect (a case may hide one that is not a candidate)."""
        from calibrax.diagnosis import effects_by_name

        return effects_by_name(None)

    def box(self) -> Box:
        return Box.around(self.space, self.centre, self.plausible)

    def design(self) -> list[DesignPoint]:
        """The diagnosis's design for every case of this model (what :func:`diagnose` runs)."""
        return design_points(self.box(), self.effects(), self.budget, self.seed)

    def calibrated(self, experiment: Any):
        """The :class:`~calibrax.diagnosis.Calibrated` a case's experiment is diagnosed from."""
        from calibrax.diagnosis import Calibrated

        return Calibrated(self.simulator, self.spec, self.space, experiment, dict(self.centre), dict(self.plausible))


def _values(path: Path, key: str, raw: Any, space: ParameterSpace, single: bool) -> dict:
    if not isinstance(raw, dict) or (single and set(raw) != set(space.names)) or set(raw) - set(space.names):
        raise ConfigError(f"{path}: {key}", f"a mapping of {list(space.names)} to "
                          f"{'values' if single else '[low, high]'}, got {raw!r}")
    out = {}
    for name, v in raw.items():
        p = space.parameters[space.names.index(name)]
        vals = [v] if single else (v if isinstance(v, list) and len(v) == 2 else None)
        if vals is None or not all(isinstance(x, (int, float)) and p.low <= x <= p.high for x in vals):
            raise ConfigError(f"{path}: {key}.{name}", f"{'a value' if single else '[low, high]'} within "
                              f"[{p.low:g}, {p.high:g}], got {v!r}")
        out[name] = float(v) if single else (float(vals[0]), float(vals[1]))
    return out
