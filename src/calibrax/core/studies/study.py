"""Running a fixed set of simulations (a cross-check, a convergence study, a diagnosis design) into a
store, with progress and resume, through the same :class:`~calibrax.core.running.scheduler.Scheduler` as a
campaign (a failure, the engine's or the executor's, is stored as data the same way) — the
campaign's machinery without the search.

A study is a list of :class:`StudyCase` s, each one spec run on one backend with several seeds. Each
case is stored as a point of a :class:`CampaignStore` (its ``acquisition`` attribute names the case),
so a killed study resumes without repeating a finished simulation, and results keep their time
series and provenance.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from calibrax.core.running.executor import SimulationTask
from calibrax.core.data.features import result_features, step_mean
from calibrax.core.running.scheduler import Finished, Scheduler
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.core.sheartest.result import ShearTestResult
from calibrax.core.sheartest.physics import steady_base_load
from calibrax.core.running.store import CampaignStore
from calibrax.core.search.records import Status
from calibrax.core.sheartest.yieldlocus import YieldLocus
from calibrax.errors import CalibraxError

log = logging.getLogger("calibrax")


@dataclass(frozen=True)
class StudyCase:
    """One spec on one backend, run with ``seeds``; ``label`` names it in tables and figures and
    ``coords`` are the case's coordinates (parameter values or fidelity knobs) for the store."""

    label: str
    backend: str
    spec: ShearCellSpec
    seeds: tuple[int, ...]
    coords: dict[str, float] = field(default_factory=dict)


def shear_window_diagnostics(result: ShearTestResult) -> dict[str, float]:
    """How the servo held σ while the head sheared, and the steady friction it left, averaged over
    the shear steps of one result (the second half of each window is taken as steady flow):

    * ``sigma_sd``: s.d. of σ in the second half of the window / target σ (fraction);
    * ``sigma_offset_at_peak``: σ measured at the τ peak / target σ − 1 (fraction). The peak is the
      largest τ of the window, and τ follows σ, so a servo that lets σ swing reads a higher peak;
    * ``steady_friction``: mean τ / mean σ over the second half of the window;
    * ``preshear_rotation``: mean rotation of the preshears, rad (steady preshears stop when τ/σ is
      steady, so this says how long the powder took to reach it);
    * ``preshear_drift``: largest relative drift of τ/σ at a preshear's end
      (:func:`~calibrax.core.sheartest.preshear_drift`; NaN for results stored before it existed).
    """
    sd, offset, friction = [], [], []
    k = 0
    for step in result.steps:
        if step.kind != "shear" or len(step.normal_stress) < 4:
            continue
        half = len(step.normal_stress) // 2
        sigma, tau = step.normal_stress[half:], step.shear_stress[half:]
        sd.append(float(np.std(sigma)) / step.target_stress)
        friction.append(float(np.mean(tau) / np.mean(sigma)))
        if k < len(result.peak_normal_stress):
            offset.append(float(result.peak_normal_stress[k]) / step.target_stress - 1.0)
        k += 1
    mean = lambda xs: float(np.nanmean(xs)) if xs else math.nan  # noqa: E731
    rot, drift = result.preshear_rotation, result.preshear_drift
    return {"sigma_sd": mean(sd), "sigma_offset_at_peak": mean(offset), "steady_friction": mean(friction),
            "preshear_rotation": float(np.mean(rot)) if rot.size else math.nan,
            "preshear_drift": float(np.max(drift)) if drift.size and np.any(np.isfinite(drift)) else math.nan}


def _robust_features(result: ShearTestResult) -> dict[str, float]:
    """The test's mean peak τ/σ_measured and mean preshear steady τ/σ (calibrax.core.data.features)."""
    f = result_features(result)
    return {stem: step_mean(f, stem) for stem in ("peak_ratio", "preshear_ratio")}


@dataclass
class CaseOutcome:
    """What one case gave: per-seed results (None where a seed failed) and the statistics."""

    case: StudyCase
    results: list[ShearTestResult | None]
    failures: list[str]

    @property
    def good(self) -> list[ShearTestResult]:
        return [r for r in self.results if r is not None]

    def locus(self) -> YieldLocus | None:
        """Peaks of every seed pooled into one locus (None if fewer than two σ)."""
        if not self.good:
            return None
        try:
            return YieldLocus.fit(np.concatenate([r.target_normal_stress for r in self.good]),
                                  np.concatenate([r.peak_shear_stress for r in self.good]))
        except CalibraxError:
            return None

    def seed_loci(self) -> list[YieldLocus]:
        out = []
        for r in self.good:
            try:
                out.append(r.yield_locus())
            except CalibraxError:
                pass
        return out

    def summary(self) -> dict[str, float]:
        """C and AIF (pooled fit) with their regression s.e., the seed-to-seed s.d., and the
        uncertainty of the estimate u = max(regression s.e., s.d./√n); mean peaks per step (Pa),
        bulk density after the first preshear (kg/m³) with its seed s.d. and u = s.d./√n; the
        seeds' mean :func:`shear_window_diagnostics`, ``base_load`` (steady τ over what a flat base can
        hold, :func:`~calibrax.core.sheartest.steady_base_load`), ``base_slip`` (the bottom layer's
        spin over the head's rate, :func:`~calibrax.core.sheartest.base_slip`) and the robust
        features ``peak_ratio`` and ``preshear_ratio`` (means over the steps, see
        :mod:`calibrax.core.data.features`), each with ``_sd``, their seed s.d."""
        locus = self.locus()
        loci = self.seed_loci()
        n = len(loci)
        out: dict[str, float] = {"seeds_ok": float(len(self.good)), "seeds_failed": float(len(self.failures))}
        if locus is None:
            return out
        c_sd = float(np.std([l.cohesion for l in loci], ddof=1)) if n >= 2 else float("nan")
        a_sd = float(np.std([l.aif_deg for l in loci], ddof=1)) if n >= 2 else float("nan")
        out.update({
            "cohesion": locus.cohesion, "cohesion_stderr": locus.cohesion_stderr, "cohesion_seed_sd": c_sd,
            "aif": locus.aif_deg, "aif_stderr": locus.aif_stderr_deg, "aif_seed_sd": a_sd,
            "cohesion_u": float(np.nanmax([locus.cohesion_stderr, c_sd / math.sqrt(n) if n >= 2 else np.nan])),
            "aif_u": float(np.nanmax([locus.aif_stderr_deg, a_sd / math.sqrt(n) if n >= 2 else np.nan])),
            "bulk_density": float(np.mean([r.bulk_density[0] for r in self.good])),
            "bulk_density_sd": float(np.std([r.bulk_density[0] for r in self.good], ddof=1))
            if len(self.good) > 1 else float("nan"),
            "wall_time": float(np.mean([r.provenance.wall_time for r in self.good])),
            "particles": float(self.good[0].provenance.particle_count),
        })
        out["bulk_density_u"] = out["bulk_density_sd"] / math.sqrt(len(self.good))
        conditioned = [r.conditioned_bulk_density for r in self.good]
        if len(conditioned) > 1 and all(math.isfinite(v) for v in conditioned):  # where the backend measures it
            out["conditioned_bulk_density"] = float(np.mean(conditioned))
            out["conditioned_bulk_density_sd"] = float(np.std(conditioned, ddof=1))
            out["conditioned_bulk_density_u"] = out["conditioned_bulk_density_sd"] / math.sqrt(len(conditioned))
        windows = [dict(shear_window_diagnostics(r), **_robust_features(r),
                        base_load=steady_base_load(self.case.spec, r.steps, r.bulk_density),
                        base_slip=float(np.nanmean(r.base_slip)) if np.any(np.isfinite(r.base_slip)) else math.nan)
                   for r in self.good]
        for key in windows[0]:
            values = [w[key] for w in windows]
            out[key] = float(np.nanmean(values))
            out[f"{key}_sd"] = float(np.nanstd(values, ddof=1)) if len(values) > 1 else float("nan")
        peaks = np.stack([r.peak_shear_stress for r in self.good])
        for k, sigma in enumerate(self.good[0].target_normal_stress):
            out[f"peak_{sigma:.0f}"] = float(peaks[:, k].mean())
            out[f"peak_{sigma:.0f}_sd"] = float(peaks[:, k].std(ddof=1)) if len(peaks) > 1 else float("nan")
        return out


def _record(store: CampaignStore, kind: str, cases: list[StudyCase], done: Finished) -> None:
    """Store one finished simulation of a study (a result or a failure) and log it."""
    i, pid, index = done.key
    seed = cases[i].seeds[index]
    result, exc, wall = done.result, done.failure, done.wall_time
    if exc is not None:
        store.add_simulation(pid, index, seed, None, reason=exc.reason, log_tail=exc.log_tail, kind=exc.kind,
                             wall_time=wall)
        log.warning("%s: %s on %s, seed %d FAILED [%s]: %s", kind, cases[i].label, cases[i].backend, seed,
                    exc.kind, exc.reason)
        return
    store.add_simulation(pid, index, seed, result, wall_time=wall)
    log.info("%s: %s on %s, seed %d done in %.0f s: peaks %s Pa", kind, cases[i].label, cases[i].backend, seed, wall,
             [round(float(t)) for t in result.peak_shear_stress])


def study_hash(cases: list[StudyCase]) -> str:
    blob = json.dumps([[c.label, c.backend, c.spec.spec_hash(), list(c.seeds)] for c in cases], sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def run_study(cases: list[StudyCase], store_path: Path, executor, workdir: Path, kind: str,
              progress: Callable[[int, int], None] | None = None, shutdown: bool = True) -> list[CaseOutcome]:
    """Run every case's seeds through ``executor`` (resuming from ``store_path``), return the outcomes.
    ``progress(finished, total)`` is called once at the start and after every simulation (finished
    counts those of earlier runs too). The executor is shut down at the end unless ``shutdown`` is
    False (a caller that runs a second study on it); on an error it always is."""
    from calibrax import __version__

    with CampaignStore(store_path).acquire(study_hash(cases)) as store:
        store.initialise(study_hash(cases), {"study": kind, "cases": [c.label for c in cases]}, __version__)
        if not store.points():
            for i, c in enumerate(cases):
                names = list(c.coords) or ["index"]
                values = np.array([list(c.coords.values()) or [float(i)]])
                store.add_batch(i, np.zeros_like(values), values, names, [list(c.seeds)], f"{c.backend}|{c.label}", None)
        records = store.points()

        def on_start(key: tuple[int, int, int]) -> None:
            i, _, index = key
            log.info("%s: %s on %s, seed %d starts in %s", kind, cases[i].label, cases[i].backend,
                     cases[i].seeds[index], workdir / f"{kind}-{records[i].id:04d}-s{index}")

        scheduler = Scheduler(executor, on_start)
        for i, (c, p) in enumerate(zip(cases, records)):
            for s in p.sims:
                if s.status == Status.PENDING:
                    spec = c.spec.replace(numerics={"seed": s.seed})
                    task = SimulationTask(p.id, c.backend, spec, workdir / f"{kind}-{p.id:04d}-s{s.index}")
                    scheduler.submit(task, (i, p.id, s.index))
        total = sum(len(c.seeds) for c in cases)
        finished = total - len(scheduler)
        if progress:
            progress(finished, total)
        try:
            while scheduler:
                for done in scheduler.wait():
                    _record(store, kind, cases, done)
                    finished += 1
                    if progress:
                        progress(finished, total)
        except BaseException:
            scheduler.shutdown(cancel=True)
            raise
        if shutdown:
            scheduler.shutdown()
        outcomes = []
        for c, p in zip(cases, store.points()):
            results = [store.result(p.id, s.index) if s.status == Status.DONE else None for s in p.sims]
            outcomes.append(CaseOutcome(c, results, [s.reason for s in p.sims if s.status == Status.FAILED]))
        return outcomes
