"""``warm_start``: a new store that starts with an earlier campaign's finished simulations.

The earlier store must have been made with the same simulator, cell (calibrated values and seed
aside) and calibrated parameters; its finished points inside this campaign's box become batch 0,
scored with this campaign's metric and experiment, and nothing is re-simulated.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from calibrax.core.resolved import without_added_defaults
from calibrax.core.search.parameters import ParameterSpace
from calibrax.core.search.records import Status
from calibrax.errors import CalibraxError, ConfigError

#: the source (``acquisition``) of the points a campaign was warm-started with
WARM_START = "warm_start"


def _comparable_cell(cell: dict[str, Any], names: tuple[str, ...]) -> dict[str, Any]:
    """A resolved cell without what differs between the points of one campaign: the calibrated
    material values and the seed."""
    cell = without_added_defaults({"cell": cell})["cell"]
    for name in names:
        cell.get("material", {}).pop(name, None)
    cell.get("numerics", {}).pop("seed", None)
    return cell


def check_warm_start(path: Path, resolved: dict[str, Any], space: ParameterSpace) -> None:
    """``warm_start`` must be a calibrax store made with the same simulator, cell (calibrated values
    and seed aside) and calibrated parameters; ConfigError naming what differs otherwise."""
    from calibrax.core.running.store import CampaignStore
    from calibrax.errors import StoreError

    if not path.is_file():
        raise ConfigError("warm_start", f"{path} is not a file; give an earlier campaign's store")
    try:
        earlier = CampaignStore(path).config()
    except (StoreError, KeyError, ValueError) as exc:
        raise ConfigError("warm_start", f"{path} is not a calibrax store ({exc})") from None
    if earlier.get("simulator") != resolved["simulator"]:
        raise ConfigError("warm_start", f"{path} was run on {earlier.get('simulator')!r}, this campaign on "
                          f"{resolved['simulator']!r}: their results are not the same experiment's")
    if sorted(earlier.get("parameters", {})) != sorted(space.names):
        raise ConfigError("warm_start", f"{path} calibrated {sorted(earlier.get('parameters', {}))}, this campaign "
                          f"{sorted(space.names)}; warm-start needs the same parameters")
    mine = _flat(_comparable_cell(resolved["cell"], space.names))
    theirs = _flat(_comparable_cell(earlier.get("cell", {}), space.names))
    diff = sorted(k for k in set(mine) | set(theirs) if mine.get(k) != theirs.get(k))
    if diff:
        raise ConfigError("warm_start", f"{path} simulated a different cell (cell.{', cell.'.join(diff[:4])} "
                          "differ); warm-start needs the same cell")


def _flat(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """{"a": {"b": 1}} → {"a.b": 1}."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out




def take_warm_start(store, space: ParameterSpace, experiment, metric, path: Path) -> tuple[int, int]:
    """Add every finished simulation of the store at ``path`` whose point lies in the box of
    ``space`` to ``store`` (batch 0, source :data:`WARM_START`), scored with ``metric`` against the
    campaign's ``experiment``. Returns (points taken, points left out as outside the box)."""
    from calibrax.core.running.store import CampaignStore

    earlier = CampaignStore(path)
    taken, outside = 0, 0
    for p in earlier.points():
        done = [s for s in p.sims if s.status == Status.DONE]
        if not done:
            continue
        params = p.params()
        natural = np.asarray([[params[n] for n in space.names]])
        if not all(q.low <= v <= q.high for q, v in zip(space.parameters, natural[0])):
            outside += 1
            continue
        (pid,) = store.add_batch(0, space.to_unit(natural), natural, list(space.names),
                                 [[s.seed for s in done]], WARM_START, None)
        results = [earlier.result(p.id, s.index) for s in done]
        value, error = None, ""
        try:
            value = metric.evaluate(results, experiment)
        except CalibraxError as exc:
            error = str(exc)
        for k, (s, result) in enumerate(zip(done, results)):
            last = k == len(done) - 1
            store.add_simulation(pid, k, s.seed, result, wall_time=s.wall_time, metric=value if last else None,
                                 metric_error=error if last else "")
        taken += 1
    return taken, outside
