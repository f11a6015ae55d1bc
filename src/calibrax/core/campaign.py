"""The calibration loop: propose → simulate in parallel → measure → record → refit.

Batch 0 is a scrambled Sobol design of ``budget.initial`` points; each later batch fits the
Kriging model on every finished point and asks the acquisition for ``q`` points (q = 2: the
paper's 2-point EI). Every proposal is written to the store *before* it runs and every result as
soon as it finishes, so ``run()`` on an existing store resumes: it re-runs only the simulations
that were in flight and goes on with the next batch.
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from calibrax.core.acquisition import Observations
from calibrax.core.config import CampaignConfig
from calibrax.core.executor import SimulationTask
from calibrax.core.metric import MetricValue
from calibrax.core.sheartest import ShearCellSpec, ShearTestResult
from calibrax.core.store import CampaignStore, PointRecord
from calibrax.core.surrogate import Kriging
from calibrax.errors import CalibraxError, SimulationFailed
from calibrax.plugins.builtin.acquisitions import sobol_points
from calibrax.plugins.manager import get_manager

log = logging.getLogger("calibrax")
HEARTBEAT_S = 30.0


@dataclass(frozen=True)
class CampaignSummary:
    """What a finished (or stopped) campaign reached."""

    store: Path
    points: int
    done: int
    failed: int
    best_id: int | None
    best_params: dict[str, float]
    best_value: float
    best_uncertainty: float


def simulation_seed(campaign_seed: int, point_id: int, index: int) -> int:
    """The seed of simulation ``index`` of point ``point_id``: distinct, reproducible, < 2³¹."""
    return (campaign_seed * 1_000_003 + point_id * 1_000 + index) % (2**31 - 1)


def point_spec(base: ShearCellSpec, params: dict[str, float], seed: int) -> ShearCellSpec:
    """The spec of one simulation: calibrated material values and the seed set on the base spec."""
    return base.replace(material=dict(params), numerics={"seed": int(seed)})


def observations(points: list[PointRecord]) -> Observations:
    """Unit-cube points and distances of every point with a metric."""
    done = [p for p in points if p.metric is not None and math.isfinite(p.metric.value)]
    if not done:
        return Observations(np.zeros((0, len(points[0].names) if points else 0)), np.zeros(0), np.zeros(0))
    return Observations(np.stack([p.unit for p in done]), np.array([p.metric.value for p in done]),
                        np.array([p.metric.uncertainty for p in done]))


def _fmt_params(params: dict[str, float]) -> str:
    return ", ".join(f"{k}={v:.4g}" for k, v in params.items())


class Campaign:
    """One calibration campaign bound to its config; :meth:`run` runs or resumes it."""

    def __init__(self, config: CampaignConfig, listener: Callable[[dict[str, Any]], None] | None = None) -> None:
        """``listener`` receives every progress event as a JSON-ready dict (``event``, ``message``, fields)."""
        self.config = config
        self.listener = listener
        manager = get_manager()
        self.metric = manager.create("metric", config.metric, **config.metric_options)
        self.acquisition = manager.create("acquisition", config.acquisition, **config.acquisition_options)
        self.engine = manager.create("simulator", config.simulator)
        self._best: tuple[float, int, dict[str, float]] | None = None

    # ------------------------------------------------------------------------------------------
    def run(self) -> CampaignSummary:
        cfg = self.config
        from calibrax import __version__

        with CampaignStore(cfg.store).acquire() as store:
            created = store.initialise(cfg.search_hash(), cfg.resolved, __version__, cfg.experiment)
            self._emit("campaign", f"{'new' if created else 'resuming'} campaign {cfg.name!r} on {cfg.simulator} "
                       f"({self.engine.version()}); store {cfg.store}", resumed=not created,
                       simulator=cfg.simulator, engine=self.engine.version(), store=str(cfg.store))
            previous = self.summary(store)
            if previous.best_id is not None:
                self._best = (previous.best_value, previous.best_id, previous.best_params)
            executor = get_manager().create("executor", cfg.executor, **cfg.executor_options)
            try:
                if not store.points():
                    unit = sobol_points(cfg.space.dim, cfg.initial, seed=cfg.seed)
                    self._add_batch(store, 0, unit, "sobol(initial)", None)
                self._run_pending(store, executor)
                while True:
                    points = store.points()
                    batch = max(p.batch for p in points) + 1
                    if batch > cfg.iterations:
                        break
                    unit, name, model = self._propose(points, batch)
                    self._add_batch(store, batch, unit, name, model)
                    self._run_pending(store, executor)
            except BaseException:
                executor.shutdown(cancel=True)
                raise
            executor.shutdown()
            return self.summary(store)

    @staticmethod
    def summary(store: CampaignStore) -> CampaignSummary:
        """The campaign's state as stored: counts and the best point so far."""
        points = store.points()
        done = [p for p in points if p.metric is not None and math.isfinite(p.metric.value)]
        failed = sum(1 for p in points if p.status == "failed")
        best = min(done, key=lambda p: p.metric.value, default=None)
        if best is None:
            return CampaignSummary(store.path, len(points), len(done), failed, None, {}, float("nan"), float("nan"))
        return CampaignSummary(store.path, len(points), len(done), failed, best.id, best.params(),
                               best.metric.value, best.metric.uncertainty)

    # ------------------------------------------------------------------------------------------
    def _propose(self, points: list[PointRecord], batch: int) -> tuple[np.ndarray, str, dict | None]:
        cfg = self.config
        obs = observations(points)
        seed = cfg.seed * 7919 + batch
        if not self.acquisition.needs_model:
            return self.acquisition.propose(None, cfg.space, obs, cfg.q, seed=seed), cfg.acquisition, None
        if len(obs.y) < 2:
            self._emit("fallback", f"batch {batch}: only {len(obs.y)} finished point(s), too few for a model; "
                       "proposing space-filling points", level=logging.WARNING, batch=batch)
            return sobol_points(cfg.space.dim, cfg.q, seed=cfg.seed, skip=len(points)), "sobol(fallback)", None
        t0 = time.monotonic()
        model = Kriging.fit(obs.x, obs.y, seed=seed)
        unit = self.acquisition.propose(model, cfg.space, obs, cfg.q, seed=seed)
        hyper = model.hyperparameters()
        self._emit("model", f"batch {batch}: Kriging on {len(obs.y)} points (length scales "
                   f"{', '.join(f'{v:.3g}' for v in hyper['lengthscales'])}, noise {hyper['noise'] or 0.0:.3g}) → "
                   f"{cfg.acquisition} proposes {cfg.q} point(s) in {time.monotonic() - t0:.1f} s",
                   batch=batch, hyperparameters=hyper)
        return unit, cfg.acquisition, hyper

    def _add_batch(self, store: CampaignStore, batch: int, unit: np.ndarray, source: str, model: dict | None) -> None:
        cfg = self.config
        natural = cfg.space.from_unit(unit)
        first = len(store.points())
        seeds = [[simulation_seed(cfg.seed, first + j, i) for i in range(cfg.seeds_per_point)] for j in range(len(unit))]
        ids = store.add_batch(batch, unit, natural, list(cfg.space.names), seeds, source, model)
        for pid, row in zip(ids, natural):
            self._emit("proposed", f"batch {batch}: point {pid} proposed by {source}: "
                       f"{_fmt_params(cfg.space.as_dict(row))}", batch=batch, point=pid, source=source,
                       params=cfg.space.as_dict(row))

    def _run_pending(self, store: CampaignStore, executor) -> None:
        cfg = self.config
        points = {p.id: p for p in store.points()}
        outcomes: dict[int, dict[int, ShearTestResult | None]] = {}
        futures: dict[cf.Future, tuple[PointRecord, int, int, float]] = {}
        for p in points.values():
            pending = [s for s in p.sims if s.status == "pending"]
            if not pending:
                continue
            outcomes[p.id] = {s.index: store.result(p.id, s.index) if s.status == "done" else None
                              for s in p.sims if s.status != "pending"}
            for s in pending:
                spec = point_spec(cfg.spec, p.params(), s.seed)
                workdir = cfg.workdir / f"p{p.id:06d}-s{s.index}"
                task = SimulationTask(p.id, cfg.simulator, spec, workdir)
                self._emit("started", f"point {p.id} sim {s.index}: {cfg.simulator} starts (seed {s.seed}, "
                           f"{_fmt_params(p.params())})", point=p.id, sim=s.index, seed=s.seed,
                           simulator=cfg.simulator, params=p.params())
                futures[executor.submit(task)] = (p, s.index, s.seed, time.monotonic())
        last_beat = time.monotonic()
        waiting = set(futures)
        while waiting:
            finished, waiting = cf.wait(waiting, timeout=5.0, return_when=cf.FIRST_COMPLETED)
            for fut in finished:
                point, index, seed, t0 = futures[fut]
                self._record(store, point, index, seed, fut, time.monotonic() - t0, outcomes[point.id])
            if time.monotonic() - last_beat >= HEARTBEAT_S and waiting:
                last_beat = time.monotonic()
                running = {futures[f][0].id: round(time.monotonic() - futures[f][3], 1)
                           for f in sorted(waiting, key=lambda f: futures[f][0].id)}
                text = ", ".join(f"point {k} ({v:.0f} s)" for k, v in running.items())
                self._emit("running", f"running: {text} | {self._best_text()}", elapsed_s=running)

    def _record(self, store: CampaignStore, point: PointRecord, index: int, seed: int, fut: cf.Future,
                wall: float, outcomes: dict[int, ShearTestResult | None]) -> None:
        """Store one finished simulation; when it is the point's last, the point's metric too."""
        cfg = self.config
        try:
            result, failure = fut.result(), None
        except SimulationFailed as exc:
            result, failure = None, exc
        outcomes[index] = result
        metric, error = None, ""
        good = [outcomes[i] for i in sorted(outcomes) if outcomes[i] is not None]
        if len(outcomes) == cfg.seeds_per_point and good:
            try:
                metric = self.metric.evaluate(good, cfg.experiment)
            except CalibraxError as exc:
                error = str(exc)
        if failure is not None:
            self._emit("failed", f"point {point.id} sim {index} ({cfg.simulator}, seed {seed}) FAILED after "
                       f"{wall:.1f} s [{failure.kind}]: {failure.reason}", level=logging.WARNING, point=point.id,
                       sim=index, seed=seed, kind=failure.kind, reason=failure.reason, wall_s=wall)
            store.add_simulation(point.id, index, seed, None, reason=failure.reason, log_tail=failure.log_tail,
                                 kind=failure.kind, wall_time=wall, metric=metric, metric_error=error)
            return
        store.add_simulation(point.id, index, seed, result, wall_time=wall, metric=metric, metric_error=error)
        for w in result.warnings:
            self._emit("warning", f"point {point.id} sim {index}: {w}", level=logging.WARNING, point=point.id)
        peaks = ", ".join(f"{t:.0f}" for t in result.peak_shear_stress)
        msg = f"point {point.id} sim {index} done in {wall:.1f} s ({cfg.simulator}, seed {seed}): τ_peak = [{peaks}] Pa"
        if metric is not None:
            f = metric.features
            msg += (f", C = {f.get('cohesion_sim', float('nan')):.0f} Pa, AIF = {f.get('aif_sim', float('nan')):.1f}°,"
                    f" d = {metric.value:.3g} ± {metric.uncertainty:.2g}")
            if self._best is None or metric.value < self._best[0]:
                self._best = (metric.value, point.id, point.params())
        elif error:
            msg += f"; metric failed: {error}"
        self._emit("done", f"{msg} | {self._best_text()}", point=point.id, sim=index, seed=seed, wall_s=wall,
                   peaks_pa=result.peak_shear_stress.tolist(),
                   distance=None if metric is None else metric.value,
                   best_point=None if self._best is None else self._best[1],
                   best_distance=None if self._best is None else self._best[0])

    def _emit(self, event: str, message: str, level: int = logging.INFO, **data: Any) -> None:
        log.log(level, "%s", message)
        if self.listener is not None:
            self.listener({"event": event, "time": time.time(), "message": message, **data})

    def _best_text(self) -> str:
        if self._best is None:
            return "no best point yet"
        v, pid, params = self._best
        return f"best d = {v:.3g} at point {pid} ({_fmt_params(params)})"


def run_campaign(config: CampaignConfig, listener: Callable[[dict[str, Any]], None] | None = None) -> CampaignSummary:
    """Run or resume the campaign of ``config``; ``listener`` gets the progress events."""
    return Campaign(config, listener).run()
