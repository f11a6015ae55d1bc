"""``calibrax crosscheck``: the same shear test on several backends, and their micro-level checks.

Macro level: every parameter point runs on every backend with N seeds; per point and backend we
report the peaks of each step, the bulk density, C and AIF with the regression s.e. and the
seed-to-seed s.d., and whether each pair of backends agrees: |Δ| ≤ 2·√(u_a² + u_b²), with
u = max(regression s.e., seed s.d./√n).

Micro level: each backend's :class:`~calibrax.core.sheartest.verification.Verification` (registered through the
``calibrax_verifications`` hook under the simulator's name) runs the analytic cases — a head-on
two-sphere collision (contact time, restitution, peak overlap), sliding on the base, rolling
resistance — at the config's material, and the values are set side by side; they agree when they
lie within 2 % of their mean. A quantity in which a backend's contact law differs by construction is
listed in its ``known_differences`` ({(case method, quantity): why}); the table then says so and why.
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import logging
import math
from dataclasses import dataclass

from calibrax.core.config import CampaignConfig
from calibrax.core.registry import get_manager
from calibrax.core.search.parameters import FIELDS, allowed_names, spec_values
from calibrax.core.studies.study import CaseOutcome, StudyCase
from calibrax.core.sheartest.verification import MICRO_CASES, MicroMaterial, Verification
from calibrax.errors import ConfigError, PluginError

log = logging.getLogger("calibrax")
MICRO_TOLERANCE = 0.02


def parse_point(text: str, config: CampaignConfig) -> dict[str, float]:
    """``youngs_modulus=2e10,geometry.wall_friction=0.2`` → {name: value}; the names a campaign
    may calibrate (:data:`~calibrax.core.search.parameters.FIELDS`)."""
    out: dict[str, float] = {}
    for item in filter(None, (t.strip() for t in text.split(","))):
        key, sep, value = item.partition("=")
        if not sep or key not in FIELDS:
            raise ConfigError("--points", f"{item!r}: expected NAME=VALUE with NAME one of {allowed_names()}")
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
    """One case per (point, backend); the same spec and seeds on every backend, except that a
    backend without rotational periodicity runs the full cell a sector spec stands for
    (``geometry.sector`` 1): the sector is a device of the simulation, not of the powder, and the
    cross-check is how it is checked against the full cell."""
    from calibrax.core.simulator import check_capabilities

    manager = get_manager()
    simulators = {}
    for b in backends:
        try:
            simulators[b] = manager.create("simulator", b)
        except PluginError as exc:
            raise ConfigError("--backends", str(exc)) from None
    cases = []
    for j, params in enumerate(points or [{}]):
        try:
            spec = config.spec.with_values(spec_values(params)).validate()
        except ConfigError as exc:
            raise ConfigError("--points", f"{params}: {exc}") from None
        specs = {b: spec if "sector" in sim.capabilities() else spec.replace(geometry={"sector": 1})
                 for b, sim in simulators.items()}
        for b, sim in simulators.items():
            try:
                check_capabilities(sim, specs[b])
            except ConfigError as exc:
                raise ConfigError("--backends", exc.message) from None
        label = ", ".join(f"{k}={v:g}" for k, v in params.items()) or "base spec"
        for b in backends:
            cases.append(StudyCase(f"P{j}: {label}", b, specs[b],
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
    """Pairwise agreement of the backends at each point (2σ of the combined uncertainty) in C and
    AIF, and in the bulk density after the first preshear and the conditioned bulk density where
    both have them from ≥ 2 seeds (their u is the seed s.d./√n)."""
    by_point: dict[str, list[CaseOutcome]] = {}
    for o in outcomes:
        by_point.setdefault(o.case.label, []).append(o)
    out = []
    for label, group in by_point.items():
        for a, b in itertools.combinations(group, 2):
            sa, sb = a.summary(), b.summary()
            for q in ("cohesion", "aif", "bulk_density", "conditioned_bulk_density"):
                if q in sa and q in sb:
                    limit = 2.0 * math.hypot(sa[f"{q}_u"], sb[f"{q}_u"])
                    if q.endswith("bulk_density") and not math.isfinite(limit):
                        continue
                    out.append(Agreement(label, q, a.case.backend, b.case.backend, sa[q] - sb[q], limit))
    return out


def verification_for(backend: str) -> Verification | None:
    """The backend's registered :class:`~calibrax.core.sheartest.verification.Verification` (None if it has
    none: its micro cases are then left out of the table)."""
    found = get_manager().plugins("verification").get(backend)
    return found.cls() if found is not None else None

#: quantities compared on an absolute scale (tolerance 2 % of max(|mean|, scale)): a relative
#: difference of values near zero, like the energy change of an elastic impact, means nothing
ABSOLUTE_SCALE = {"energy_change": 1.0}
#: not compared: inputs and bookkeeping
NOT_COMPARED = {"error", "dt"}


def micro_material(config: CampaignConfig) -> MicroMaterial:
    """The material of the micro cases: the config's material and radius."""
    m = config.spec.material
    return MicroMaterial(radius=config.spec.radius, youngs_modulus=m.youngs_modulus, poisson_ratio=m.poisson_ratio,
                         density=m.density, restitution=m.restitution, friction=m.sliding_friction,
                         rolling_friction=m.rolling_friction)


def _micro_backend(backend: str, material: MicroMaterial) -> dict[str, dict[str, float]]:
    """{case: {quantity: value}} of every micro case of ``backend``'s verification."""
    verification = verification_for(backend)
    out: dict[str, dict[str, float]] = {}
    if verification is None:
        return out
    for case, (method, changes) in MICRO_CASES.items():
        if not hasattr(verification, method):  # a case of an effect the backend does not model
            continue
        log.info("crosscheck: micro case %r on %s", case, backend)
        try:
            values = getattr(verification, method)(material.replace(**changes))
        except Exception as exc:  # noqa: BLE001 — a failed check is shown as such, not a crash
            values = {"error": f"{type(exc).__name__}: {exc}"}
        out[case] = {k: (float(v) if k != "error" else v) for k, v in values.items()
                     if (isinstance(v, (int, float)) and not isinstance(v, bool)) or k == "error"}
    return out


def micro_checks(config: CampaignConfig, backends: list[str],
                 workers: int = 1) -> dict[str, dict[str, dict[str, float]]]:
    """{case: {backend: {quantity: value}}} of every micro case each backend implements, at the
    config's material; up to ``workers`` backends at once (LIGGGHTS and YADE run as subprocesses)."""
    material = micro_material(config)
    with cf.ThreadPoolExecutor(max_workers=max(1, min(workers, len(backends)))) as pool:
        per_backend = dict(zip(backends, pool.map(lambda b: _micro_backend(b, material), backends)))
    out: dict[str, dict[str, dict[str, float]]] = {}
    for case in MICRO_CASES:
        for backend in backends:
            if case in per_backend[backend]:
                out.setdefault(case, {})[backend] = per_backend[backend][case]
    return out


def known_differences(backends: list[str]) -> dict[str, dict[tuple[str, str], str]]:
    """{backend: {(case method, quantity): why}} from each backend's verification: the micro-level
    quantities in which its contact law differs by construction."""
    out = {}
    for b in backends:
        verification = verification_for(b)
        out[b] = dict(verification.known_differences) if verification is not None else {}
    return out


@dataclass(frozen=True)
class MicroRow:
    """One micro-level quantity measured by several backends.

    ``agree``: all values within 2 % of their mean (of max(|mean|, scale) for ``ABSOLUTE_SCALE``
    quantities). ``known``: when they do not agree, the backends whose contact law is documented
    to differ in this quantity (their module's ``KNOWN_DIFFERENCES``) and ``others_agree``: whether
    the remaining backends agree among themselves."""

    case: str
    quantity: str
    values: dict[str, float]
    agree: bool
    known: tuple[str, ...] = ()
    others_agree: bool = True


def _within(values: list[float], quantity: str) -> bool:
    if len(values) < 2:
        return True
    mean = sum(values) / len(values)
    spread = max(values) - min(values)
    return spread <= MICRO_TOLERANCE * max(abs(mean), ABSOLUTE_SCALE.get(quantity, 0.0))


def micro_agreement(checks: dict[str, dict[str, dict[str, float]]],
                    known: dict[str, dict[tuple[str, str], str]] | None = None) -> list[MicroRow]:
    """One row per quantity measured by ≥ 2 backends (see :class:`MicroRow`)."""
    known = known or {}
    rows = []
    for case, per_backend in checks.items():
        function = MICRO_CASES.get(case, (case, {}))[0]
        keys = set.intersection(*(set(v) for v in per_backend.values())) if per_backend else set()
        for key in sorted(keys - NOT_COMPARED):
            values = {b: float(v[key]) for b, v in per_backend.items()}
            if len(values) < 2:
                continue
            agree = _within(list(values.values()), key)
            flagged: tuple[str, ...] = ()
            others = True
            if not agree:
                flagged = tuple(b for b in values if (function, key) in known.get(b, {}))
                others = _within([v for b, v in values.items() if b not in flagged], key)
            rows.append(MicroRow(case, key, values, agree, flagged, others))
    return rows


def micro_errors(checks: dict[str, dict[str, dict[str, float]]]) -> list[tuple[str, str, str]]:
    """(case, backend, error) of every micro case that raised."""
    return [(case, b, str(v["error"])) for case, per_backend in checks.items() for b, v in per_backend.items()
            if "error" in v]
