"""A campaign's trials as a flat table: one row per parameter point (``calibrax export``, or
``calibrax.trial_rows`` from Python), as Ax's and Optuna's trial data frames.

Columns: ``id, batch, source`` (and ``fidelity``, in a multi-fidelity campaign), ``state``; each parameter with its unit (``youngs_modulus_Pa``,
``sliding_friction``); ``distance, distance_sd, noise_threshold, within_noise``; the simulated and
the experiment's ``C_Pa, AIF_deg``; ``simulations, seeds`` (``;``-separated), ``wall_s`` (the
engines' time, summed over the point's simulations), ``peak_tau_<σ>kPa_Pa`` (mean over the point's
finished simulations) and ``failures`` (reasons, ``;``-separated). Unknown values are empty cells.
"""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from calibrax.core.studies.campaign import Campaign
from calibrax.core.search.parameters import UNITS
from calibrax.core.running.store import CampaignStore
from calibrax.core.search.records import Status
from calibrax.errors import StoreError
from calibrax.report.status import point_state


def _column(name: str) -> str:
    unit = UNITS.get(name, "-")
    return name if unit == "-" else f"{name}_{unit.replace('/', '_').replace('³', '3')}"


def _num(value: Any) -> float | None:
    return float(value) if isinstance(value, (int, float)) and math.isfinite(value) else None


def trial_rows(store: CampaignStore | str | Path) -> list[dict[str, Any]]:
    """One dict per point of the campaign ``store``, keys as the module's columns; None where unknown."""
    store = store if isinstance(store, CampaignStore) else CampaignStore(store)
    points = store.points()
    best = Campaign.summary(store).best_id
    live = store.in_use()
    workdir = store.config().get("workdir") if points else None
    peaks_of = {p.id: _peaks(store, p) or {} for p in points}  # each point's results read once
    sigmas = sorted({float(s) for peaks in peaks_of.values() for s in peaks})
    rows = []
    for p in points:
        f = p.metric.features if p.metric is not None else {}
        value = _num(p.metric.value) if p.metric is not None else None
        threshold = _num(f.get("noise_threshold"))
        walls = [s.wall_time for s in p.sims if math.isfinite(s.wall_time)]
        peaks = peaks_of[p.id]
        row: dict[str, Any] = {"id": p.id, "batch": p.batch, "source": p.acquisition,
                               **({"fidelity": p.fidelity} if p.fidelity else {}),
                               "state": point_state(workdir, p, live), "best": p.id == best}
        row.update({_column(n): float(v) for n, v in zip(p.names, p.natural)})
        row.update({
            "distance": value, "distance_sd": _num(p.metric.uncertainty) if p.metric is not None else None,
            "noise_threshold": threshold,
            "within_noise": None if value is None or threshold is None else value <= threshold,
            "C_Pa": _num(f.get("cohesion_sim")), "AIF_deg": _num(f.get("aif_sim")),
            "C_exp_Pa": _num(f.get("cohesion_exp")), "AIF_exp_deg": _num(f.get("aif_exp")),
            "simulations": len(p.sims), "seeds": ";".join(str(s.seed) for s in p.sims),
            "wall_s": sum(walls) if walls else None,
        })
        row.update({f"peak_tau_{s / 1e3:g}kPa_Pa": peaks.get(s) for s in sigmas})
        row["failures"] = ";".join(f"sim {s.index} [{s.kind}]: {s.reason}" for s in p.sims if s.status == Status.FAILED)
        rows.append(row)
    return rows


def _peaks(store: CampaignStore, point) -> dict[float, float] | None:
    """Mean peak τ (Pa) per target σ (Pa) over the point's finished simulations."""
    results = [store.result(point.id, s.index) for s in point.sims if s.status == Status.DONE]
    if not results:
        return None
    out = {}
    for sigma in sorted({float(v) for r in results for v in r.target_normal_stress}):
        values = [float(t) for r in results for t, s in zip(r.peak_shear_stress, r.target_normal_stress)
                  if float(s) == sigma]
        out[sigma] = float(np.mean(values))
    return out


def write_trials_csv(store: CampaignStore | str | Path, path: str | Path) -> Path:
    """Write :func:`trial_rows` as CSV to ``path`` (written aside, then renamed: never half-written)."""
    rows = trial_rows(store)
    if not rows:
        raise StoreError(f"store {getattr(store, 'path', store)} has no points yet: nothing to export")
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: "" if v is None else v for k, v in row.items()})
    os.replace(tmp, path)
    return path
