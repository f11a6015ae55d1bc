"""``calibrax crosscheck``: the same shear test on several backends, and their micro-level checks.

Macro level: every parameter point runs on every backend with N seeds; per point and backend we
report the peaks of each step, the bulk density, C and AIF with the regression s.e. and the
seed-to-seed s.d., and whether each pair of backends agrees: |Δ| ≤ 2·√(u_a² + u_b²), with
u = max(regression s.e., seed s.d./√n).

Micro level: each backend's ``verification`` module (the sibling module ``verification`` of its
simulator class) runs the analytic cases — a head-on two-sphere collision (contact time,
restitution, peak overlap), sliding on the base, rolling resistance — and the values are set side
by side; they agree when they lie within 2 % of their mean.
"""

from __future__ import annotations

import importlib
import inspect
import itertools
import logging
import math
from dataclasses import dataclass
from types import ModuleType
from typing import Any

from calibrax.core.config import CampaignConfig
from calibrax.core.study import CaseOutcome, StudyCase
from calibrax.errors import ConfigError, PluginError
from calibrax.plugins.manager import get_manager

log = logging.getLogger("calibrax")
MICRO_TOLERANCE = 0.02


def parse_point(text: str, config: CampaignConfig) -> dict[str, float]:
    """``youngs_modulus=2e10,sliding_friction=0.5`` → {name: value}; names are Material fields."""
    out: dict[str, float] = {}
    for item in filter(None, (t.strip() for t in text.split(","))):
        key, sep, value = item.partition("=")
        if not sep or key not in config.spec.material.__dataclass_fields__:
            raise ConfigError("--points", f"{item!r}: expected NAME=VALUE with NAME one of "
                              f"{sorted(config.spec.material.__dataclass_fields__)}")
        try:
            number = float(value)
        except ValueError:
            raise ConfigError("--points", f"{item!r}: {value!r} is not a number") from None
        if not math.isfinite(number):
            raise ConfigError("--points", f"{item!r}: must be finite")
        out[key] = number
    return out


def crosscheck_cases(config: CampaignConfig, backends: list[str], seeds: int,
                     points: list[dict[str, float]]) -> list[StudyCase]:
    """One case per (point, backend); the same spec and seeds on every backend."""
    manager = get_manager()
    for b in backends:
        try:
            manager.get("simulator", b)
        except PluginError as exc:
            raise ConfigError("--backends", str(exc)) from None
    cases = []
    for j, params in enumerate(points or [{}]):
        spec = config.spec.replace(material=dict(params)).validate()
        label = ", ".join(f"{k}={v:g}" for k, v in params.items()) or "base spec"
        for b in backends:
            cases.append(StudyCase(f"P{j}: {label}", b, spec,
                                   tuple(config.seed * 1000 + 17 * j + s for s in range(seeds)),
                                   {**params, "point": float(j)}))
    return cases


@dataclass(frozen=True)
class Agreement:
    """Whether two backends agree on one quantity at one point."""

    point: str
    quantity: str
    backend_a: str
    backend_b: str
    difference: float
    limit: float

    @property
    def agree(self) -> bool:
        return math.isfinite(self.difference) and abs(self.difference) <= self.limit


def agreements(outcomes: list[CaseOutcome]) -> list[Agreement]:
    """Pairwise C and AIF agreement of the backends at each point (2σ of the combined uncertainty)."""
    by_point: dict[str, list[CaseOutcome]] = {}
    for o in outcomes:
        by_point.setdefault(o.case.label, []).append(o)
    out = []
    for label, group in by_point.items():
        for a, b in itertools.combinations(group, 2):
            sa, sb = a.summary(), b.summary()
            for q in ("cohesion", "aif"):
                if q in sa and q in sb:
                    limit = 2.0 * math.hypot(sa[f"{q}_u"], sb[f"{q}_u"])
                    out.append(Agreement(label, q, a.case.backend, b.case.backend, sa[q] - sb[q], limit))
    return out


def verification_module(backend: str) -> ModuleType | None:
    """The backend's ``verification`` module, beside its simulator class (None if it has none)."""
    cls = get_manager().get("simulator", backend).cls
    package = cls.__module__.rsplit(".", 1)[0]
    try:
        return importlib.import_module(f"{package}.verification")
    except ImportError:
        return None


MICRO_CASES: dict[str, tuple[str, dict[str, Any]]] = {
    "collision e=1": ("two_sphere_collision", {"restitution": 1.0}),
    "collision e=material": ("two_sphere_collision", {}),
    "sliding on base": ("sliding_on_base", {}),
    "rolling resistance": ("rolling_resistance", {}),
}


def micro_checks(config: CampaignConfig, backends: list[str]) -> dict[str, dict[str, dict[str, float]]]:
    """{case: {backend: {quantity: value}}} of every micro case each backend implements."""
    m, radius = config.spec.material, config.spec.radius
    material = {"radius": radius, "youngs_modulus": m.youngs_modulus, "poisson_ratio": m.poisson_ratio,
                "density": m.density, "restitution": m.restitution, "friction": m.sliding_friction,
                "rolling_friction": m.rolling_friction}
    out: dict[str, dict[str, dict[str, float]]] = {}
    for backend in backends:
        module = verification_module(backend)
        for case, (function, fixed) in MICRO_CASES.items():
            fn = getattr(module, function, None) if module is not None else None
            if fn is None:
                continue
            accepted = inspect.signature(fn).parameters
            kwargs = {k: v for k, v in {**material, **fixed}.items() if k in accepted}
            log.info("crosscheck: micro case %r on %s", case, backend)
            try:
                values = fn(**kwargs)
            except Exception as exc:  # noqa: BLE001 — a failed check is shown as such, not a crash
                values = {"error": str(exc)}
            out.setdefault(case, {})[backend] = {k: v for k, v in values.items()
                                                 if isinstance(v, (int, float)) or k == "error"}
    return out


def micro_agreement(checks: dict[str, dict[str, dict[str, float]]]) -> list[tuple[str, str, dict[str, float], bool]]:
    """(case, quantity, {backend: value}, agree) for quantities measured by ≥ 2 backends."""
    rows = []
    for case, per_backend in checks.items():
        keys = set.intersection(*(set(v) for v in per_backend.values())) if per_backend else set()
        for key in sorted(keys - {"error", "dt"}):
            values = {b: float(v[key]) for b, v in per_backend.items()}
            if len(values) < 2:
                continue
            mean = sum(values.values()) / len(values)
            spread = max(values.values()) - min(values.values())
            agree = spread <= MICRO_TOLERANCE * abs(mean) if mean else spread == 0
            rows.append((case, key, values, agree))
    return rows
