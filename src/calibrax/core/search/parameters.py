"""The calibrated parameters: names, bounds, log scale, and the map to and from the unit cube.

The surrogate and the acquisitions work in the unit cube [0, 1]^d; simulators see natural
values (Pa for ``youngs_modulus``, dimensionless for frictions). A log-scaled parameter is
uniform in log10 on the cube, as E is in the paper's search over decades of stiffness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from calibrax.errors import ConfigError

@dataclass(frozen=True)
class CalibratableField:
    """One material field (:class:`~calibrax.core.sheartest.Material`) a campaign may calibrate.

    Attributes:
        name: the ``material`` field and the campaign file's parameter name.
        unit: its SI unit ("-": dimensionless), for tables and axes.
        low, high: the range a search box may span (both inclusive).
        symbol: the symbol answers, logs and figures show (``E``, ``μs``).
        display_scale, display_unit: what the value is multiplied by for display, and the unit
            then (E shown in GPa: 1e-9, "GPa").
    """

    name: str
    unit: str
    low: float
    high: float
    symbol: str
    display_scale: float = 1.0
    display_unit: str = ""


#: the one registry of calibratable parameters; everything else (the allowed ranges, the units,
#: the display symbols) is read off it, and a unit test checks it against the Material fields
FIELDS: dict[str, CalibratableField] = {f.name: f for f in (
    CalibratableField("youngs_modulus", "Pa", 1.0e5, 1.0e13, "E", 1e-9, "GPa"),
    CalibratableField("sliding_friction", "-", 0.0, 5.0, "μs"),
    CalibratableField("rolling_friction", "-", 0.0, 5.0, "μr"),
    CalibratableField("restitution", "-", 1.0e-3, 1.0, "e"),
    CalibratableField("poisson_ratio", "-", 0.0, 0.49999, "ν"),
    CalibratableField("density", "kg/m³", 1.0, 1.0e5, "ρ", 1.0, "kg/m³"),
    CalibratableField("cohesion_energy_density", "J/m³", 0.0, 1.0e9, "k_coh", 1e-3, "kJ/m³"),
    CalibratableField("bond_number", "-", 0.0, 100.0, "Bo"),
)}
#: {name: (low, high)}: the range each calibratable parameter's box may span
CALIBRATABLE: dict[str, tuple[float, float]] = {n: (f.low, f.high) for n, f in FIELDS.items()}
#: {name: unit} for tables and axes ("-": dimensionless)
UNITS: dict[str, str] = {n: f.unit for n, f in FIELDS.items()}
#: {name: (symbol, display scale, display unit)}
DISPLAY: dict[str, tuple[str, float, str]] = {n: (f.symbol, f.display_scale, f.display_unit) for n, f in FIELDS.items()}


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
                              f"allowed names: {sorted(CALIBRATABLE)}")
        params = []
        for name, body in raw.items():
            k = f"{key}.{name}"
            if name not in CALIBRATABLE:
                raise ConfigError(k, f"unknown parameter; allowed: {sorted(CALIBRATABLE)}")
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
            lo_ok, hi_ok = CALIBRATABLE[name]
            if low < lo_ok or high > hi_ok:
                raise ConfigError(k, f"bounds must lie within [{lo_ok:g}, {hi_ok:g}], got [{low:g}, {high:g}]")
            if log and low <= 0:
                raise ConfigError(f"{k}.low", "must be > 0 for a log-scaled parameter")
            params.append(Parameter(name, low, high, log))
        return cls(tuple(params))
