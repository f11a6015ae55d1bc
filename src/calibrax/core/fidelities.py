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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.errors import ConfigError

#: CPU-seconds per test on one core (docs/how-to/choose-a-preset.md#what-a-test-costs): ``tiny``
#: about 70 s, ``quick`` about 250 s, ``paper`` about 700 times the former ``quick``'s 116 s
NOMINAL_COST_S = {"tiny": 70.0, "quick": 250.0, "paper": 81_200.0}
ENTRY_KEYS = {"preset": "a fidelity preset name", "cost": "CPU-seconds per simulation (> 0)",
              "initial": "points of the initial design at this fidelity (integer ≥ 0)"}


@dataclass(frozen=True)
class Fidelity:
    """One fidelity of a campaign.

    Attributes:
        name: the preset's name (``tiny``, ``quick``, ``paper``).
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


def nearest(fidelities: tuple[Fidelity, ...], level: float) -> Fidelity:
    """The fidelity whose level is nearest ``level`` (an acquisition's proposal)."""
    return min(fidelities, key=lambda f: abs(f.level - level))


def target_fidelity(store) -> str:
    """The target fidelity's name of a multi-fidelity campaign's store ("" for one fidelity)."""
    fidelities = store.config().get("fidelities")
    return fidelities[-1]["preset"] if fidelities else ""
