"""The calibrated parameters: names, bounds, log scale, and the map to and from the unit cube.

The surrogate and the acquisitions work in the unit cube [0, 1]^d; simulators see natural
values (Pa for ``youngs_modulus``, dimensionless for frictions). A log-scaled parameter is
uniform in log10 on the cube, as E is in the paper's search over decades of stiffness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from calibrax.core.sheartest.fields import FieldInfo, declared_fields
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.errors import ConfigError

@dataclass(frozen=True)
class CalibratableField:
    """One spec field a campaign may calibrate, as the spec declares it
    (:class:`~calibrax.core.sheartest.fields.FieldInfo`).

    Attributes:
        name: the campaign file's parameter name: the dotted path (``geometry.wall_friction``), or
            a :class:`~calibrax.core.sheartest.Material` field's bare name (``sliding_friction``).
        path: the dotted path of the spec field it sets (``material.sliding_friction``).
        unit: its SI unit ("-": dimensionless), for tables and axes.
        low, high: the range a search box may span; ``info.contains`` says which ends are open.
        symbol: the symbol answers, logs and figures show (``E``, ``μs``).
        display_scale, display_unit: what the value is multiplied by for display, and the unit
            then (E shown in GPa: 1e-9, "GPa").
        capability: the backend capability a value other than ``off`` needs, or None.
        info: the declaration itself.
    """

    name: str
    path: str
    unit: str
    low: float
    high: float
    symbol: str
    display_scale: float = 1.0
    display_unit: str = ""
    capability: str | None = None
    info: FieldInfo | None = None


def _calibratable_fields() -> dict[str, CalibratableField]:
    """Every calibratable field by dotted path, and each material field by its bare name too."""
    out: dict[str, CalibratableField] = {}
    for path, info in declared_fields(ShearCellSpec):
        if not info.calibratable:
            continue
        names = (path, path.split(".", 1)[1]) if path.startswith("material.") else (path,)
        for name in names:
            out[name] = CalibratableField(name, path, info.unit, info.low, info.high, info.symbol,
                                          info.display_scale, info.display_unit or info.unit.strip("-"), info.capability,
                                          info)
    return out


#: the calibratable parameters by name, read off the spec's declarations (the one place a field's
#: unit, symbol and range are written: :mod:`calibrax.core.sheartest.spec`)
FIELDS: dict[str, CalibratableField] = _calibratable_fields()
#: {name: (low, high)}: the range each calibratable parameter's box may span
CALIBRATABLE: dict[str, tuple[float, float]] = {n: (f.low, f.high) for n, f in FIELDS.items()}
#: {name: unit} for tables and axes ("-": dimensionless)
UNITS: dict[str, str] = {n: f.unit for n, f in FIELDS.items()}
#: {name: (symbol, display scale, display unit)}
DISPLAY: dict[str, tuple[str, float, str]] = {n: (f.symbol, f.display_scale, f.display_unit) for n, f in FIELDS.items()}


def spec_path(name: str) -> str:
    """The dotted spec path a parameter ``name`` sets (a bare name is a material field's)."""
    return FIELDS[name].path if name in FIELDS else name


def spec_values(params: dict[str, float]) -> dict[str, float]:
    """``{parameter name: value}`` as ``{dotted spec path: value}``, for
    :meth:`~calibrax.core.sheartest.ShearCellSpec.with_values`."""
    return {spec_path(name): value for name, value in params.items()}


@dataclass(frozen=True)
class Parameter:
    """One calibrated parameter: ``low`` < ``high`` in natural units, optionally log-scaled."""

    name: str
    low: float
    high: float
    log: bool = False

    def to_unit(self, value: np.ndarray | float) -> np.ndarray:
        """Natural value(s) → [0, 1]."""
        v = np.asarray(value, dtype=float)
        if self.log:
            return (np.log10(v) - math.log10(self.low)) / (math.log10(self.high) - math.log10(self.low))
        return (v - self.low) / (self.high - self.low)

    def from_unit(self, u: np.ndarray | float) -> np.ndarray:
        """[0, 1] → natural value(s)."""
        u = np.asarray(u, dtype=float)
        if self.log:
            lo, hi = math.log10(self.low), math.log10(self.high)
            return 10.0 ** (lo + u * (hi - lo))
        return self.low + u * (self.high - self.low)


@dataclass(frozen=True)
class ParameterSpace:
    """An ordered set of :class:`Parameter`; column j of every array is ``parameters[j]``."""

    parameters: tuple[Parameter, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def dim(self) -> int:
        return len(self.parameters)

    def to_unit(self, natural: np.ndarray) -> np.ndarray:
        """Shape (n, d) natural values → shape (n, d) unit-cube coordinates."""
        x = np.atleast_2d(np.asarray(natural, dtype=float))
        return np.column_stack([p.to_unit(x[:, j]) for j, p in enumerate(self.parameters)])

    def from_unit(self, unit: np.ndarray) -> np.ndarray:
        """Shape (n, d) unit-cube coordinates → shape (n, d) natural values (clipped into the cube)."""
        u = np.clip(np.atleast_2d(np.asarray(unit, dtype=float)), 0.0, 1.0)
        return np.column_stack([p.from_unit(u[:, j]) for j, p in enumerate(self.parameters)])

    def as_dict(self, natural_row: np.ndarray) -> dict[str, float]:
        """One natural point, shape (d,) → {name: value}."""
        return {p.name: float(v) for p, v in zip(self.parameters, np.asarray(natural_row, dtype=float))}

    @classmethod
    def from_config(cls, raw: object, key: str = "parameters") -> "ParameterSpace":
        """Build from the campaign's ``parameters:`` mapping, validating every entry."""
        if not isinstance(raw, dict) or not raw:
            raise ConfigError(key, f"must be a non-empty mapping of parameter name → {{low, high, log}}; "
                              f"allowed names: {allowed_names()}")
        params = []
        for name, body in raw.items():
            k = f"{key}.{name}"
            if name not in CALIBRATABLE:
                raise ConfigError(k, f"unknown parameter; allowed: {allowed_names()}")
            if not isinstance(body, dict):
                raise ConfigError(k, "must be a mapping with keys low, high and optionally log")
            unknown = set(body) - {"low", "high", "log"}
            if unknown:
                raise ConfigError(f"{k}.{sorted(unknown)[0]}", "unknown key; allowed: ['high', 'log', 'low']")
            for bound in ("low", "high"):
                if bound not in body:
                    raise ConfigError(f"{k}.{bound}", "is required")
                v = body[bound]
                if isinstance(v, str):  # PyYAML reads 5.0e9 as text
                    try:
                        v = body[bound] = float(v)
                    except ValueError:
                        pass
                if isinstance(v, bool) or not isinstance(v, (int, float)):
                    raise ConfigError(f"{k}.{bound}", f"must be a number, got {type(v).__name__} {v!r}")
                if not math.isfinite(v):
                    raise ConfigError(f"{k}.{bound}", f"must be finite, got {v!r}")
            low, high = float(body["low"]), float(body["high"])
            log = body.get("log", False)
            if not isinstance(log, bool):
                raise ConfigError(f"{k}.log", f"must be true or false, got {log!r}")
            if low >= high:
                raise ConfigError(k, f"low must be < high, got low={low:g}, high={high:g}")
            info = FIELDS[name].info
            if not (info.contains(low) and info.contains(high)):
                raise ConfigError(k, f"bounds must lie {info.interval()} ({FIELDS[name].path}), "
                                  f"got [{low:g}, {high:g}]")
            if log and low <= 0:
                raise ConfigError(f"{k}.low", "must be > 0 for a log-scaled parameter")
            params.append(Parameter(name, low, high, log))
        paths = [spec_path(p.name) for p in params]
        twice = sorted({path for path in paths if paths.count(path) > 1})
        if twice:
            raise ConfigError(key, f"{twice[0]} is named twice (by its bare name and its dotted path); name it once")
        return cls(tuple(params))


def allowed_names() -> str:
    """The parameter names a campaign may calibrate, for error messages: every calibratable dotted
    path; a material field may also be named bare."""
    return f"{sorted(n for n in FIELDS if '.' in n)} (a material field also by its bare name, e.g. sliding_friction)"


def check_parameter_capabilities(simulator: Any, space: ParameterSpace) -> None:
    """Refuse a calibrated parameter whose box reaches values the backend ``simulator`` (a
    :class:`~calibrax.core.simulator.Simulator`: its ``name`` and ``capabilities()``) cannot model,
    naming the parameter and the capability its declaration gives
    (:class:`~calibrax.core.sheartest.fields.FieldInfo`)."""
    for p in space.parameters:
        field = FIELDS.get(p.name)
        if field is not None and field.capability is not None and field.capability not in simulator.capabilities():
            raise ConfigError(f"parameters.{p.name}", f"{simulator.name} cannot model {field.capability!r}, which "
                              f"{field.path} other than {field.info.off!r} needs; it models "
                              f"{sorted(simulator.capabilities())}")
