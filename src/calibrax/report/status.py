"""``calibrax status``: a campaign store as a table a user can read at a glance.

Every parameter's column carries its unit and its whole name; a pending point says whether its
simulations are running, queued or interrupted (from the store's lock and each simulation's
``attempts.log``); the footer gives the experiment's targets and the distance's scales, so that a
large distance can be read (a tight experiment makes every point far away).
"""

from __future__ import annotations

import math
from pathlib import Path

from calibrax.core.studies.campaign import Campaign
from calibrax.core.studies.simulation_setup import simulation_workdir
from calibrax.core.running.executor import ATTEMPTS_LOG
from calibrax.core.search.metric import SIMULATED_FEATURES, simulated_features
from calibrax.core.search.parameters import UNITS
from calibrax.core.running.store import CampaignStore
from calibrax.core.search.records import PointRecord, Status

#: display name and unit of the metric's features named ``<stem>_exp`` (others: the stem, no unit)
FEATURE_LABELS = {"cohesion": ("C", " Pa"), "aif": ("AIF", "°"), "bulk_density": ("bulk density", " kg/m³")}


def _with_unit(name: str, value: float) -> str:
    """"youngs_modulus = 1.493e+10 Pa", "sliding_friction = 0.574" (no unit for a dimensionless one)."""
    unit = UNITS.get(name, "-")
    return f"{name} = {value:.4g}" + ("" if unit == "-" else f" {unit}")


def simulation_state(workdir: str | None, point: PointRecord, index: int, live: bool) -> str:
    """"done", "failed", "running", "queued" (a live campaign has not started it yet) or
    "interrupted" (the campaign stopped before it finished; a new run resumes it)."""
    sim = point.sims[index]
    if sim.status != Status.PENDING:
        return str(sim.status)
    if not live:
        return "interrupted"
    if not workdir:  # a crosscheck's or converge's store: its work folders are named otherwise
        return "in flight"
    log = simulation_workdir(Path(workdir), point.id, index) / ATTEMPTS_LOG
    lines = log.read_text(errors="replace").splitlines() if log.exists() else []
    return "running" if lines and " started " in f"{lines[-1]} " else "queued"


def point_state(workdir: str | None, point: PointRecord, live: bool) -> str:
    """The point's state: done or failed ("no metric": simulated, but no distance, as in a
    crosscheck's store), else the most advanced of its simulations' states."""
    if point.status == Status.FAILED and all(s.status == Status.DONE for s in point.sims):
        return "no metric"
    if point.status != Status.PENDING:
        return str(point.status)
    states = {simulation_state(workdir, point, s.index, live) for s in point.sims}
    return next((s for s in ("running", "in flight", "queued", "interrupted") if s in states), "pending")


def _fmt(value: float, spec: str) -> str:
    return format(value, spec) if math.isfinite(value) else ""


def status_text(store: CampaignStore) -> str:
    """The table, the counts, the best point and the experiment's targets, as printed."""
    points = store.points()
    summary = Campaign.summary(store)
    live = store.in_use()
    workdir = store.config().get("workdir") if points else None  # the campaign's work folders (a study's: none)
    names = points[0].names if points else []
    labels = [f"{n} [{UNITS.get(n, '-')}]" for n in names]
    widths = [max(len(label), 10) for label in labels]
    # the simulated features the metric states (c_aif: C and AIF; robust: τ/σ and density)
    shown = next((simulated_features(p.metric.features) for p in points if p.metric), []) or \
        [e for e in SIMULATED_FEATURES if e[0] in ("cohesion_sim", "aif_sim")]
    feature_labels = [f"{label} [{unit or '-'}]" for _, label, unit, _ in shown]
    head = (f"{'id':>3} {'batch':>5} {'source':<16} " + " ".join(f"{lab:>{w}}" for lab, w in zip(labels, widths))
            + f" {'status':<11} " + " ".join(f"{lab:>{max(9, len(lab))}}" for lab in feature_labels)
            + f" {'distance':>15} {'wall [s]':>9}")
    lines = [head, "-" * len(head)]
    states = {}
    for p in points:
        states[p.id] = point_state(workdir, p, live)
        f = p.metric.features if p.metric else {}
        dist = f"{p.metric.value:.3g} ± {p.metric.uncertainty:.2g}" if p.metric else ""
        walls = [s.wall_time for s in p.sims if math.isfinite(s.wall_time)]
        mark = " *" if p.id == summary.best_id else ""
        source = f"{p.acquisition[:9]}@{p.fidelity}" if p.fidelity else p.acquisition  # "mfei@tiny"
        lines.append(f"{p.id:>3} {p.batch:>5} {source[:16]:<16} "
                     + " ".join(f"{v:>{w}.4g}" for v, w in zip(p.natural, widths))
                     + f" {states[p.id]:<11} "
                     + " ".join(f"{_fmt(f.get(key, math.nan), fmt):>{max(9, len(lab))}}"
                                for (key, _, _, fmt), lab in zip(shown, feature_labels))
                     + f" {dist:>15}"
                     f" {_fmt(sum(walls), '.1f') if walls else '':>9}{mark}")
        for s in p.sims:
            if s.status == Status.FAILED:
                lines.append(f"      sim {s.index} failed [{s.kind}]: {s.reason}")
    counts = {k: sum(1 for v in states.values() if v == k)
              for k in ("done", "no metric", "failed", "running", "in flight", "queued", "interrupted")}
    text = ", ".join(f"{n} {k}" for k, n in counts.items() if n or k in ("done", "failed"))
    lines.append(f"\n{len(points)} points: {text}" + ("; the campaign is running" if live else ""))
    lines.extend(cell_lines(store))
    lines.extend(fidelity_lines(store, points))
    if counts["interrupted"]:
        lines.append("interrupted simulations run again when the campaign is run again (calibrax run CAMPAIGN.yaml)")
    if summary.answer is not None:
        from calibrax.core.search.answer import Answer

        lines.append(f"answer: {Answer.from_dict(summary.answer).summary()}")
    if summary.best_id is not None:
        params = ", ".join(_with_unit(k, v) for k, v in summary.best_params.items())
        lines.append(f"best observed (*; one draw of the noise, not the answer): point {summary.best_id}: {params}; "
                     f"distance {summary.best_value:.3g} ± {summary.best_uncertainty:.2g}, {summary.noise_text()}")
    lines.extend(experiment_lines(points))
    return "\n".join(lines)


def cell_lines(store: CampaignStore) -> list[str]:
    """The campaign's cell in words (:meth:`ShearCellSpec.cell_words`), [] if the store holds no
    readable cell (a multi-fidelity campaign's cells are its fidelities')."""
    from calibrax.core.sheartest.spec import ShearCellSpec

    config = store.config()
    cell = config.get("cell")
    if not isinstance(cell, dict) or config.get("fidelities"):
        return []
    try:
        return [f"cell: {ShearCellSpec.from_dict(cell).cell_words()}"]
    except (TypeError, ValueError, KeyError):
        return []


def fidelity_lines(store: CampaignStore, points: list[PointRecord]) -> list[str]:
    """A multi-fidelity campaign's points and CPU-seconds per fidelity, and which one the answer
    speaks of ([] for one fidelity)."""
    fidelities = store.config().get("fidelities")
    if not fidelities:
        return []
    parts = []
    for f in fidelities:
        mine = [p for p in points if p.fidelity == f["preset"]]
        cpu = sum(s.wall_time for p in mine for s in p.sims if math.isfinite(s.wall_time))
        parts.append(f"{f['preset']} {len(mine)} points, {cpu:.3g} CPU-s")
    return [f"fidelities (cheapest first; the answer and the best observed point are {fidelities[-1]['preset']}'s): "
            + "; ".join(parts)]


def experiment_lines(points: list[PointRecord]) -> list[str]:
    """The experiment's values of the metric's features and the scales the distance divides by
    (d² = Σ ((sim − exp) / scale)²), from the first point with a metric; [] if none has one."""
    f = next((p.metric.features for p in points if p.metric is not None), None)
    if not f:
        return []
    targets, scales = [], []
    for key in [k for k in f if k.endswith("_exp")]:
        stem = key[: -len("_exp")]
        label, unit = FEATURE_LABELS.get(stem, (stem, ""))
        targets.append(f"{label} = {f[key]:.4g}{unit}")
        scale = f.get(f"scale_{stem}", f.get(f"{stem}_scale"))
        if scale is not None and math.isfinite(scale):
            scales.append(f"{label} {scale:.4g}{unit}")
    out = [f"experiment: {', '.join(targets)}"]
    if scales:
        out.append(f"distance: d² = Σ ((sim − exp) / scale)² with scales {', '.join(scales)} "
                   "(a tight experiment has small scales, and every point is far from it)")
    return out
