"""A campaign's fidelities: the cells it may simulate at, each with its cost (``fidelities:``).

A multi-fidelity campaign names two or more fidelity presets, cheapest first; the last is the
*target*, the fidelity its answer is stated at. Each entry is a preset name, or a mapping::

    fidelities:
      - tiny                                   # nominal cost, no initial points of its own
      - {preset: quick, cost: 250, initial: 3}

``cost`` is the CPU-seconds one simulation takes (default :data:`NOMINAL_COST_S`, measured on
one core of the 2-core development machine, Table 1 material); only the ratios matter to the
search. ``initial`` is how many points of the initial design run at that fidelity (default: the
cheapest takes ``budget.initial``, the target ``max(2, ⌈initial/3⌉)``, the others none); every
fidelity's initial points are the first ones of the same Sobol sequence, so that the levels are
*nested* (each target point has its cheap twin, what co-Kriging learns the bias from).

The model sees a fidelity as one more input, its *level* s in [0, 1]: s = log(c/c_min) /
log(c_max/c_min), 0 for the cheapest and 1 for the target (on a log-cost scale, as cell sizes and
time steps multiply the cost).

A campaign asks its :class:`FidelityPlan` (``CampaignConfig.plan``), not its ``fidelities``, what
they decide: which fidelity the initial design, the enqueued and the proposed points run at, the
levels the model sees, the cell a point runs, the progress line's CPU per fidelity, the model's
name in the log. :class:`SingleFidelity` answers for a campaign at one cell, :class:`MultiFidelity`
for several.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Protocol

import numpy as np

from calibrax.core.search.design import sobol_points
from calibrax.core.search.summary import duration_text
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.errors import ConfigError

if TYPE_CHECKING:
    from calibrax.core.search.records import PointRecord

#: CPU-seconds per test on one core (docs/how-to/choose-a-preset.md#what-a-test-costs): ``tiny``
#: about 70 s, ``quick`` about 250 s, ``converged`` 2 524 s (the median of its first 7 seeds on one
#: thread, both cores busy; 10 give 2 532: docs/explanation/sector.md#the-converged-preset), ``paper`` about 700 times the former ``quick``'s 116 s
NOMINAL_COST_S = {"tiny": 70.0, "quick": 250.0, "converged": 2524.0, "paper": 81_200.0}
ENTRY_KEYS = {"preset": "a fidelity preset name", "cost": "CPU-seconds per simulation (> 0)",
              "initial": "points of the initial design at this fidelity (integer ≥ 0)"}


@dataclass(frozen=True)
class Fidelity:
    """One fidelity of a campaign.

    Attributes:
        name: the preset's name (``tiny``, ``quick``, ``converged``, ``paper``).
        spec: the campaign's cell at this preset (shape (), no batch).
        cost: CPU-seconds per simulation (or any unit common to every fidelity).
        level: the model's fidelity input, in [0, 1] (1: the target).
        initial: points of the initial design simulated at this fidelity.
    """

    name: str
    spec: ShearCellSpec
    cost: float
    level: float
    initial: int

    def to_dict(self) -> dict[str, Any]:
        """What the resolved config records (the spec is the cell's, recorded by name)."""
        return {"preset": self.name, "cost": self.cost, "level": self.level, "initial": self.initial}


def _entry(i: int, raw: Any) -> tuple[str, float | None, int | None]:
    key = f"fidelities[{i}]"
    if isinstance(raw, str):
        return raw, None, None
    if not isinstance(raw, dict):
        raise ConfigError(key, f"must be a preset name or a mapping with keys {sorted(ENTRY_KEYS)}, "
                          f"got {type(raw).__name__} {raw!r}")
    for k in raw:
        if k not in ENTRY_KEYS:
            raise ConfigError(f"{key}.{k}", "unknown key; allowed: " +
                              ", ".join(f"{n} ({what})" for n, what in ENTRY_KEYS.items()))
    if "preset" not in raw:
        raise ConfigError(f"{key}.preset", "is required: the fidelity preset this entry runs")
    cost = raw.get("cost")
    if cost is not None and (isinstance(cost, bool) or not isinstance(cost, (int, float))
                             or not math.isfinite(cost) or cost <= 0):
        raise ConfigError(f"{key}.cost", f"must be a finite number > 0 (CPU-seconds per simulation), got {cost!r}")
    initial = raw.get("initial")
    if initial is not None and (isinstance(initial, bool) or not isinstance(initial, int) or initial < 0):
        raise ConfigError(f"{key}.initial", f"must be an integer ≥ 0, got {initial!r}")
    return raw["preset"], None if cost is None else float(cost), initial


def parse_fidelities(raw: Any, build: Callable[[str], ShearCellSpec], presets: list[str],
                     budget_initial: int) -> tuple[Fidelity, ...]:
    """Validate ``fidelities:`` (cheapest first) and build each one's spec with ``build(preset)``.

    Raises:
        ConfigError: naming ``fidelities`` or the entry (``fidelities[1].cost``) and what is allowed.
    """
    if not isinstance(raw, list) or len(raw) < 2:
        raise ConfigError("fidelities", f"must be a list of two or more fidelity presets, cheapest first, the "
                          f"target last (e.g. [tiny, quick]), got {raw!r}")
    entries = [_entry(i, r) for i, r in enumerate(raw)]
    for i, (name, cost, _) in enumerate(entries):
        if not isinstance(name, str) or name not in presets:
            raise ConfigError(f"fidelities[{i}]", f"unknown preset {name!r}; allowed: {sorted(presets)}")
        if any(name == other for other, _, _ in entries[:i]):
            raise ConfigError(f"fidelities[{i}]", f"preset {name!r} is listed twice; name each fidelity once")
        if cost is None and name not in NOMINAL_COST_S:
            raise ConfigError(f"fidelities[{i}].cost", f"is required for preset {name!r} (no nominal cost known)")
    costs = [cost if cost is not None else NOMINAL_COST_S[name] for name, cost, _ in entries]
    for i in range(1, len(costs)):
        if costs[i] <= costs[i - 1]:
            raise ConfigError(f"fidelities[{i}]", f"costs {costs[i]:g} CPU-s per simulation, no more than "
                              f"fidelities[{i - 1}] ({costs[i - 1]:g}); list the fidelities cheapest first, the "
                              "target (the answer's fidelity) last")
    last = len(entries) - 1
    defaults = [budget_initial if i == 0 else max(2, math.ceil(budget_initial / 3)) if i == last else 0
                for i in range(len(entries))]
    initial = [n if n is not None else d for (_, _, n), d in zip(entries, defaults)]
    if initial[last] < 2:
        raise ConfigError(f"fidelities[{last}].initial", f"the target fidelity needs at least 2 initial points "
                          f"(what the model learns the cheap levels' bias from), got {initial[last]}")
    span = math.log(costs[-1] / costs[0])
    return tuple(Fidelity(name, build(name), cost, math.log(cost / costs[0]) / span, n)
                 for (name, _, _), cost, n in zip(entries, costs, initial))


def campaign_fidelities(raw: dict[str, Any], initial: int,
                        build_spec: Callable[[Any, Any], ShearCellSpec]) -> tuple[Fidelity, ...]:
    """A campaign mapping's ``fidelities:`` parsed, each preset built with ``build_spec(cell,
    material)`` on the campaign's ``cell`` with its preset replaced (empty without the key).
    ``cell.preset`` may then be left out, or name the target."""
    from calibrax.core.sheartest.presets import FIDELITY_PRESETS

    if "fidelities" not in raw:
        return ()
    cell = raw.get("cell") or {}
    fids = parse_fidelities(raw["fidelities"], lambda preset: build_spec({**cell, "preset": preset}, raw.get("material")),
                            sorted(FIDELITY_PRESETS), initial)
    if isinstance(cell, dict) and "preset" in cell and cell["preset"] != fids[-1].name:
        raise ConfigError("cell.preset", f"is {cell['preset']!r}, but the campaign's target fidelity (the last of "
                          f"fidelities) is {fids[-1].name!r}; leave cell.preset out, or name the target")
    return fids


def is_multi_fidelity(acquisition: str) -> bool:
    """Whether the acquisition plugin chooses a fidelity with each point (``multi_fidelity``)."""
    from calibrax.core.registry import get_manager

    return bool(getattr(get_manager().get("acquisition", acquisition).cls, "multi_fidelity", False))


def check_multi_fidelity(raw: dict[str, Any], acquisition: str, warm_start: Any) -> None:
    """What a multi-fidelity campaign cannot take: a one-fidelity acquisition, the composite model,
    a warm start (an earlier store's points carry no fidelity)."""
    if not is_multi_fidelity(acquisition):
        raise ConfigError("acquisition", f"{acquisition!r} proposes at one fidelity; with fidelities use a "
                          "multi-fidelity acquisition: mfei (the default) or mfkg")
    if acquisition == "mfkg" and isinstance(raw.get("surrogate"), dict) and raw["surrogate"].get("model") == "composite":
        raise ConfigError("surrogate.model", "mfkg (BoTorch's knowledge gradient) needs one model of the distance "
                          "over (parameters, fidelity), not the composite one: set model: distance, or use mfei")
    if warm_start is not None:
        raise ConfigError("warm_start", "a multi-fidelity campaign cannot be warm-started (an earlier store's "
                          "points carry no fidelity); leave warm_start out")


def target_fidelity(store) -> str:
    """The target fidelity's name of a multi-fidelity campaign's store ("" for one fidelity)."""
    fidelities = store.config().get("fidelities")
    return fidelities[-1]["preset"] if fidelities else ""


class FidelityPlan(Protocol):
    """What a campaign asks of its fidelities, answered once for one fidelity
    (:class:`SingleFidelity`) or several (:class:`MultiFidelity`), so that the campaign does not
    branch on them. A fidelity's name is what a point records ("" with one fidelity)."""

    #: {fidelity name: level} for the model and the answer (None with one fidelity)
    levels: dict[str, float] | None
    #: the model's name in log lines ("Kriging", "multi-fidelity Kriging")
    model_name: str

    def initial_points(self, initial: int) -> int:
        """Points of the initial design (``initial``: the config's ``budget.initial``)."""

    def initial_design(self, enqueued: np.ndarray, dim: int, initial: int,
                       seed: int) -> tuple[np.ndarray, list[str] | None]:
        """Batch 0's rows (unit cube: the ``enqueued`` ones first, then a scrambled Sobol design)
        and each row's fidelity (None with one fidelity)."""

    def at_target(self, n: int) -> list[str] | None:
        """The fidelities of ``n`` points run at the target (enqueued points); None with one."""

    def at_cheapest(self, n: int) -> list[str] | None:
        """The fidelities of ``n`` points run at the cheapest (a proposal made without a model)."""

    def pending_rows(self, pending: list[PointRecord]) -> np.ndarray | None:
        """The points in flight as the acquisition's ``X_pending`` (None: none)."""

    def propose(self, acquisition: Any, model: Any, space: Any, observations: Any, q: int,
                pending: np.ndarray | None, seed: int) -> tuple[np.ndarray, list[str] | None]:
        """``q`` points proposed by ``acquisition`` on ``model`` (unit cube, (q, d)) and the
        fidelity each runs at (None with one fidelity)."""

    def is_target(self, point: PointRecord) -> bool:
        """Whether ``point`` ran at the target fidelity (the answer's)."""

    def spec(self, point: PointRecord) -> ShearCellSpec:
        """The cell ``point``'s simulations run (before its parameters and seed are set)."""

    def cell_words(self) -> str:
        """The cell (or each fidelity's) in words, for the campaign's first log line
        (:meth:`ShearCellSpec.cell_words`)."""

    def progress(self, cpu: dict[str, list[float]], time_left: str) -> str:
        """What follows "k of N simulations done": ``time_left`` (", about 2 min left") with one
        fidelity; with several, the CPU-seconds and simulations so far per fidelity (``cpu``:
        {name: [seconds, simulations]}), as which fidelity the rest runs at is the search's choice."""


@dataclass(frozen=True)
class SingleFidelity:
    """A campaign at one fidelity: every point runs ``spec``."""

    cell: ShearCellSpec
    levels: None = None
    model_name: str = "Kriging"

    def initial_points(self, initial: int) -> int:
        return initial

    def initial_design(self, enqueued: np.ndarray, dim: int, initial: int,
                       seed: int) -> tuple[np.ndarray, list[str] | None]:
        design = sobol_points(dim, initial, seed=seed)
        return (np.vstack([enqueued, design]) if len(enqueued) else design), None

    def at_target(self, n: int) -> None:
        return None

    def at_cheapest(self, n: int) -> None:
        return None

    def pending_rows(self, pending: list[PointRecord]) -> np.ndarray | None:
        return np.stack([p.unit for p in pending]) if pending else None

    def propose(self, acquisition: Any, model: Any, space: Any, observations: Any, q: int,
                pending: np.ndarray | None, seed: int) -> tuple[np.ndarray, None]:
        return acquisition.propose(model, space, observations, q, pending=pending, seed=seed), None

    def is_target(self, point: PointRecord) -> bool:
        return True

    def spec(self, point: PointRecord) -> ShearCellSpec:
        return self.cell

    def cell_words(self) -> str:
        return f"cell: {self.cell.cell_words()}"

    def progress(self, cpu: dict[str, list[float]], time_left: str) -> str:
        return time_left


@dataclass(frozen=True)
class MultiFidelity:
    """A multi-fidelity campaign: ``fidelities`` cheapest first, the target last."""

    fidelities: tuple[Fidelity, ...]
    model_name: str = "multi-fidelity Kriging"

    @property
    def levels(self) -> dict[str, float]:
        return {f.name: f.level for f in self.fidelities}

    @property
    def target(self) -> Fidelity:
        return self.fidelities[-1]

    def initial_points(self, initial: int) -> int:
        return sum(f.initial for f in self.fidelities)

    def initial_design(self, enqueued: np.ndarray, dim: int, initial: int,
                       seed: int) -> tuple[np.ndarray, list[str]]:
        """Each fidelity runs the first ``initial`` points of one Sobol sequence (nested levels:
        every target point has its cheap twins); the enqueued points run at the target."""
        design = sobol_points(dim, max(f.initial for f in self.fidelities), seed=seed)
        rows = [enqueued] + [design[:f.initial] for f in self.fidelities]
        names = self.at_target(len(enqueued)) + [f.name for f in self.fidelities for _ in range(f.initial)]
        return np.vstack(rows), names

    def at_target(self, n: int) -> list[str]:
        return [self.target.name] * n

    def at_cheapest(self, n: int) -> list[str]:
        return [self.fidelities[0].name] * n

    def pending_rows(self, pending: list[PointRecord]) -> np.ndarray | None:
        """The pending points with their fidelity's level as one more column."""
        if not pending:
            return None
        levels = self.levels
        return np.hstack([np.stack([p.unit for p in pending]), [[levels[p.fidelity]] for p in pending]])

    def propose(self, acquisition: Any, model: Any, space: Any, observations: Any, q: int,
                pending: np.ndarray | None, seed: int) -> tuple[np.ndarray, list[str]]:
        """The acquisition proposes (x, level) rows; each level becomes the nearest fidelity."""
        rows = acquisition.propose(model, space, observations, q, pending=pending, seed=seed,
                                   fidelities=[(f.level, f.cost) for f in self.fidelities])
        return rows[:, :-1], [self.nearest(lv).name for lv in rows[:, -1]]

    def nearest(self, level: float) -> Fidelity:
        """The fidelity whose level is nearest ``level`` (an acquisition's proposal)."""
        return min(self.fidelities, key=lambda f: abs(f.level - level))

    def is_target(self, point: PointRecord) -> bool:
        return point.fidelity == self.target.name

    def spec(self, point: PointRecord) -> ShearCellSpec:
        """The point's fidelity's cell (the target's for a point stored without one)."""
        if not point.fidelity:
            return self.target.spec
        return next(f.spec for f in self.fidelities if f.name == point.fidelity)

    def cell_words(self) -> str:
        return "cells: " + "; ".join(f"{f.name} {f.spec.cell_words()}" for f in self.fidelities)

    def progress(self, cpu: dict[str, list[float]], time_left: str) -> str:
        spent = [(f.name, *cpu[f.name]) for f in self.fidelities if f.name in cpu]
        return "; CPU " + ", ".join(f"{name} {duration_text(t)} ({n:.0f} sims)" for name, t, n in spent)


def fidelity_plan(fidelities: tuple[Fidelity, ...], spec: ShearCellSpec) -> FidelityPlan:
    """The plan of a campaign with ``fidelities`` (empty: one fidelity, every point at ``spec``)."""
    return MultiFidelity(fidelities) if fidelities else SingleFidelity(spec)
