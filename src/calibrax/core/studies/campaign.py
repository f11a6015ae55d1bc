"""The calibration loop: propose → simulate in parallel → measure → record → refit.

Batch 0 is the hand-chosen ``enqueue`` points followed by a scrambled Sobol design of
``budget.initial`` points. Then, until ``enqueued + initial + iterations × q`` points have been
proposed (points enqueued on a later resume run first, as the next batch):

* ``batching: sync`` (the paper's way): when every simulation of a batch has finished, fit the
  Kriging model on every finished point and ask the acquisition for ``q`` points at once;
* ``batching: async``: whenever a worker frees up, ask for one point with the points still
  running passed to BoTorch as pending (``X_pending``), so that no worker idles waiting for its
  partner.

Every proposal is written to the store *before* it runs and every result as soon as it finishes,
so ``run()`` on an existing store resumes: it re-runs only the simulations that were in flight.
The simulations run through :class:`~calibrax.core.running.scheduler.Scheduler`, the loop every study
shares; the campaign keeps only what is its own: ask the model, screen proposals, decide when to
stop.

Failures are data: a simulation that crashed, returned NaN, blew up or timed out is stored with
its reason and log tail. For the search, a point that failed for a physical reason enters the
Kriging model with a *penalty* distance (the worst finished distance plus 10 % of the observed
range), which steers the acquisition away from its neighbourhood, and no point is ever proposed
again within 1e-3 (unit-cube units) of an existing one: such a proposal is replaced by a
space-filling point.

The campaign's result is its :class:`~calibrax.core.search.answer.Answer`, not the best observation (a lucky
seed on noisy DEM): the minimiser of the Kriging model's posterior mean with the region of plausible
parameters, refitted after every batch and stored, and printed at the end.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from calibrax.core.fidelities import target_fidelity
from calibrax.core.search.answer import Answer
from calibrax.core.config import CampaignConfig
from calibrax.core.running.executor import SimulationTask
from calibrax.core.search.metric import describe_simulated
from calibrax.core.sheartest.result import ShearTestResult
from calibrax.core.search.design import sobol_points
from calibrax.core.registry import get_manager
from calibrax.core.running.scheduler import Finished, Scheduler
from calibrax.core.search.summary import CampaignSummary, duration_text, noise_text
from calibrax.core.search.points import (DUPLICATE_TOL, SETTLED_MOVE, SETTLED_SHARE, campaign_answer,
                                         fit_distance_model, observations, screen_repeats, settled)
from calibrax.core.running.store import CampaignStore
from calibrax.core.search.records import PointRecord, Status
from calibrax.core.studies.simulation_setup import point_spec, simulation_seed, simulation_workdir
from calibrax.core.warm_start import WARM_START, take_warm_start
from calibrax.errors import CalibraxError

log = logging.getLogger("calibrax")
HEARTBEAT_S = 30.0


@dataclass
class _InFlight:
    """One submitted simulation (the scheduler knows it as ``(point.id, index)``)."""

    point: PointRecord
    index: int
    seed: int
    workdir: Path

    @property
    def key(self) -> tuple[int, int]:
        return self.point.id, self.index


def _fmt_params(params: dict[str, float]) -> str:
    return ", ".join(f"{k}={v:.4g}" for k, v in params.items())


class Campaign:
    """One calibration campaign bound to its config; :meth:`run` runs or resumes it."""

    def __init__(self, config: CampaignConfig, listener: Callable[[dict[str, Any]], None] | None = None) -> None:
        """``listener`` receives every progress event as a JSON-ready dict (``event``, ``message``, fields)."""
        self.config = config
        #: what the fidelities decide: which one each point runs at, the model's levels, progress
        self.plan = config.plan
        self.listener = listener
        manager = get_manager()
        self.metric = manager.create("metric", config.metric, **config.metric_options)
        self.acquisition = manager.create("acquisition", config.acquisition, **config.acquisition_options)
        self.engine = manager.create("simulator", config.simulator)
        self._best: tuple[float, int, dict[str, float]] | None = None
        self._best_noise: tuple[float, float] = (math.nan, math.nan)
        self._jobs: dict[tuple[int, int], _InFlight] = {}  # in flight, by the scheduler's key
        self._scheduler: Scheduler | None = None
        self._outcomes: dict[int, dict[int, ShearTestResult | None]] = {}
        #: simulations the whole campaign runs, those started or stored so far, and the engine's
        #: own wall times (s) of those finished in this run (for the time left)
        self._sims_total = 0
        self._sims_started = 0
        self._sims_finished = 0
        self._engine_walls: list[float] = []
        self._capacity = 1
        self._model = None  # the last Kriging model fitted for a proposal
        self._answers: list[Answer] = []  # this run's answers, one per model batch
        self._stopped = False  # the answer settled (budget.patience): no more proposals
        #: CPU-seconds (engine wall time) and simulations finished so far, per fidelity ("" for one)
        self._cpu: dict[str, list[float]] = {}

    # ------------------------------------------------------------------------------------------
    def run(self) -> CampaignSummary:
        cfg = self.config
        from calibrax import __version__

        with CampaignStore(cfg.store).acquire(cfg.search_hash(), cfg.store_mismatch) as store:
            created = store.initialise(cfg.search_hash(), cfg.resolved, __version__, cfg.experiment,
                                       mismatch=cfg.store_mismatch)
            if created and cfg.warm_start is not None:
                self._warm_start(store, cfg.warm_start)
            points = store.points()
            target = self._target(points)
            self._sims_total = max(target, len(points)) * cfg.seeds_per_point
            stored = sum(1 for p in points for s in p.sims if s.status != Status.PENDING)
            self._sims_started = self._sims_finished = stored
            for p in points:
                for s in p.sims:
                    if s.status != Status.PENDING and math.isfinite(s.wall_time):
                        self._count_cpu(p.fidelity, s.cpu_seconds(cfg.spec.numerics.threads))
            complete = len(points) >= target and stored == len(points) * cfg.seeds_per_point
            if created:
                state = "new campaign"
            elif complete:
                state = f"campaign complete ({len(points)} points, {stored} simulations stored; nothing to run):"
            else:
                state = f"resuming campaign ({stored} of {self._sims_total} simulations stored)"
            self._emit("campaign", f"{state} {cfg.name!r} on {cfg.simulator} ({self.engine.version()}), "
                       f"{cfg.batching} batches of q = {cfg.q}; {cfg.plan.cell_words()}; store {cfg.store}, "
                       f"work folders in {cfg.workdir}",
                       resumed=not created, complete=complete, simulator=cfg.simulator, engine=self.engine.version(),
                       store=str(cfg.store), workdir=str(cfg.workdir), simulations=self._sims_total)
            previous = self.summary(store)
            if previous.best_id is not None:
                self._best = (previous.best_value, previous.best_id, previous.best_params)
                self._best_noise = (previous.noise_threshold, previous.noise_threshold_rate)
            executor = get_manager().create("executor", cfg.executor, **cfg.executor_options)
            self._scheduler = Scheduler(executor, on_start=self._on_start)
            self._capacity = self._scheduler.capacity
            try:
                for p in store.points():
                    self._submit(p)
                if not [p for p in store.points() if p.acquisition != WARM_START]:
                    self._initial_design(store)
                self._loop(store)
            except BaseException:
                self._scheduler.shutdown(cancel=True)
                raise
            self._scheduler.shutdown()
            self._answer(store)
            return self.summary(store)

    def _loop(self, store: CampaignStore) -> None:
        """Ask for points while the budget allows (sync: when a batch has finished; async: when a
        worker is free), and record what the scheduler returns, until nothing is in flight."""
        cfg = self.config
        executor = self._scheduler.executor
        last_beat = time.monotonic()
        while True:
            points = store.points()
            target = self._target(points)
            running = {job.point.id for job in self._jobs.values()}
            if len(points) < target and not self._stopped:
                batch = max(p.batch for p in points) + 1
                enq = self._unqueued(points)
                if len(enq) and (cfg.batching == "async" or not running):
                    self._add_batch(store, batch, enq, "enqueued", None, self.plan.at_target(len(enq)))
                    continue
                if cfg.batching == "sync" and not running:
                    self._propose_and_submit(store, points, batch, min(cfg.q, target - len(points)))
                    continue
                free = executor.capacity - len(running)
                finished = sum(1 for p in points if p.metric is not None)
                if cfg.batching == "async" and free > 0 and (finished >= 2 or not running):
                    self._propose_and_submit(store, points, batch, min(free, target - len(points)),
                                             pending=[p for p in points if p.id in running])
                    continue
            if not self._jobs:
                return
            for done in self._scheduler.wait():
                self._record(store, self._jobs.pop(done.key), done)
            if time.monotonic() - last_beat >= HEARTBEAT_S and self._jobs:
                last_beat = time.monotonic()
                self._heartbeat()

    def _initial_design(self, store: CampaignStore) -> None:
        """Batch 0: the enqueued points (at the target fidelity), then a scrambled Sobol design;
        in a multi-fidelity campaign each fidelity runs the first ``initial`` points of one Sobol
        sequence (nested levels: every target point has its cheap twins)."""
        cfg = self.config
        enq = self._unqueued(store.points())
        rows, names = self.plan.initial_design(enq, cfg.space.dim, cfg.initial, cfg.seed)
        sources = ["enqueued"] * len(enq) + ["sobol(initial)"] * (len(rows) - len(enq))
        self._add_batch(store, 0, rows, sources, None, names)

    def _target(self, points: list[PointRecord]) -> int:
        """Points the campaign simulates: the config's, plus those it was warm-started with."""
        return self.config.target_points + sum(1 for p in points if p.acquisition == WARM_START)

    def _warm_start(self, store: CampaignStore, path: Path) -> None:
        """Start a new store with an earlier one's finished simulations (:func:`take_warm_start`)."""
        taken, outside = take_warm_start(store, self.config.space, self.config.experiment, self.metric, path)
        self._emit("warm_start", f"warm start from {path}: {taken} finished point(s) taken"
                   + (f", {outside} outside this box left out" if outside else ""), points=taken, outside=outside)

    def _unqueued(self, points: list[PointRecord]) -> np.ndarray:
        """The enqueued points (unit cube, shape (k, dim)) not yet in the store."""
        cfg = self.config
        if not cfg.enqueue:
            return np.zeros((0, cfg.space.dim))
        rows = cfg.space.to_unit(np.asarray(cfg.enqueue, dtype=float))
        taken = np.stack([p.unit for p in points]) if points else np.zeros((0, cfg.space.dim))
        new = [r for r in rows if not len(taken) or np.min(np.max(np.abs(taken - r), axis=1)) >= DUPLICATE_TOL]
        return np.stack(new) if new else np.zeros((0, cfg.space.dim))

    def _answer(self, store: CampaignStore, points: list[PointRecord] | None = None, model=None) -> None:
        """Store (and log) the campaign's answer from ``model`` fitted on ``points`` (default: refit
        on every point in the store); nothing with fewer than 3 finished points."""
        points = store.points() if points is None else points
        cfg = self.config
        answer = campaign_answer(points, cfg.space, cfg.surrogate, cfg.seed, self.plan.levels, model)
        if answer is None:
            return
        n = answer.n_points
        store.write_answer(answer.to_dict())
        self._emit("answer", f"answer from {n} points: {answer.summary()}", answer=answer.to_dict())
        self._answers.append(answer)

    def _check_settled(self) -> None:
        """budget.patience: stop proposing once the answer has settled."""
        if not self._stopped and settled(self._answers, self.config.space, self.config.patience):
            self._stopped = True
            self._emit("stopped_early", f"stopping early: the answer has settled for {self.config.patience} batches "
                       f"(recommendation within {SETTLED_MOVE:.0%} of the box, plausible region within "
                       f"{SETTLED_SHARE:.0%} of it); budget.patience = 0 runs the whole budget",
                       patience=self.config.patience)

    def _on_start(self, key: tuple[int, int]) -> None:
        """A worker took this simulation: log its start ("simulation k of N …")."""
        job = self._jobs[key]
        self._sims_started += 1
        p, cfg = job.point, self.config
        self._emit("started", f"simulation {self._sims_started} of {self._sims_total}: point {p.id} sim {job.index}: "
                   f"{cfg.simulator} starts{_at(p)} (seed {job.seed}, {_fmt_params(p.params())}) in {job.workdir}",
                   point=p.id, sim=job.index, seed=job.seed, simulator=cfg.simulator, params=p.params(),
                   workdir=str(job.workdir), number=self._sims_started, of=self._sims_total,
                   **({"fidelity": p.fidelity} if p.fidelity else {}))

    def _heartbeat(self) -> None:
        """"running: point 3 sim 0 (40 s); queued: point 4 sim 0 | 2 of 6 simulations done, … | best …"."""
        now = time.monotonic()
        jobs = sorted(self._jobs.values(), key=lambda j: j.key)
        started = {j.key: self._scheduler.started_at(j.key) for j in jobs}
        running = [(f"point {j.point.id} sim {j.index}", now - started[j.key]) for j in jobs if started[j.key] is not None]
        queued = [f"point {j.point.id} sim {j.index}" for j in jobs if started[j.key] is None]
        text = "running: " + (", ".join(f"{name} ({t:.0f} s)" for name, t in running) or "none")
        if queued:
            text += f"; queued: {', '.join(queued)}"
        self._emit("running", f"{text} | {self._progress_text()} | {self._best_text()}",
                   running={name: round(t, 1) for name, t in running}, queued=queued)

    def _progress_text(self) -> str:
        """"3 of 6 simulations done, about 2 min left" (the time left: median engine time of this
        run's finished simulations × those left ÷ workers), or the CPU spent per fidelity
        (:meth:`~calibrax.core.fidelities.FidelityPlan.progress`)."""
        text = f"{self._sims_finished} of {self._sims_total} simulations done"
        return text + self.plan.progress(self._cpu, self._time_left())

    def _time_left(self) -> str:
        """", about 2 min left" ("" before a simulation of this run has finished, or after the last)."""
        left = self._sims_total - self._sims_finished
        if left > 0 and self._engine_walls:
            eta = float(np.median(self._engine_walls)) * math.ceil(left / self._capacity)
            return f", about {duration_text(eta)} left"
        return ""

    def _count_cpu(self, fidelity: str, seconds: float) -> None:
        spent = self._cpu.setdefault(fidelity, [0.0, 0.0])
        spent[0] += seconds
        spent[1] += 1

    @staticmethod
    def summary(store: CampaignStore) -> CampaignSummary:
        """The campaign's state as stored: counts, the best observed point so far (in a multi-
        fidelity campaign, at the target fidelity) and the answer."""
        points = store.points()
        target = target_fidelity(store)
        done = [p for p in points if p.metric is not None and math.isfinite(p.metric.value)
                and p.fidelity == target]
        failed = sum(1 for p in points if p.status == Status.FAILED)
        best = min(done, key=lambda p: p.metric.value, default=None)
        if best is None:
            return CampaignSummary(store.path, len(points), len(done), failed, None, {}, float("nan"), float("nan"))
        return CampaignSummary(store.path, len(points), len(done), failed, best.id, best.params(),
                               best.metric.value, best.metric.uncertainty, best.metric.threshold,
                               best.metric.threshold_rate, store.answer())

    # ------------------------------------------------------------------------------------------
    def _propose_and_submit(self, store: CampaignStore, points: list[PointRecord], batch: int, q: int,
                            pending: list[PointRecord] | None = None) -> None:
        unit, source, model, fidelities = self._propose(points, batch, q, pending or [])
        unit = self._without_repeats(unit, points, batch)
        self._add_batch(store, batch, unit, source, model, fidelities)
        if self._model is not None:
            self._answer(store, points, self._model)
            self._check_settled()

    def _propose(self, points: list[PointRecord], batch: int, q: int,
                 pending: list[PointRecord]) -> tuple[np.ndarray, str, dict | None, list[str] | None]:
        """``q`` points (unit cube, (q, d)), what proposed them, the model's hyperparameters and,
        in a multi-fidelity campaign, the fidelity each runs at (else None)."""
        cfg, plan = self.config, self.plan
        levels = plan.levels
        obs = observations(points, levels=levels)
        seed = cfg.seed * 7919 + batch
        x_pending = plan.pending_rows(pending)
        self._model = None
        cheapest = plan.at_cheapest(q)
        if not self.acquisition.needs_model:
            unit = self.acquisition.propose(None, cfg.space, obs, q, pending=x_pending, seed=seed)
            return unit, cfg.acquisition, None, cheapest
        finished = sum(1 for p in points if p.metric is not None)
        if finished < 2:
            self._emit("fallback", f"batch {batch}: only {finished} finished point(s), too few for a model; "
                       "proposing space-filling points", level=logging.WARNING, batch=batch)
            return sobol_points(cfg.space.dim, q, seed=cfg.seed, skip=len(points)), "sobol(fallback)", None, cheapest
        t0 = time.monotonic()
        model = self._model = fit_distance_model(points, cfg.surrogate, seed, obs, levels)
        unit, fidelities = plan.propose(self.acquisition, model, cfg.space, obs, q, x_pending, seed)
        hyper = model.hyperparameters()
        n_pen = len(obs.y) - finished
        hyper.update({"penalised_failures": n_pen, "pending": 0 if x_pending is None else len(x_pending)})
        kind = ("composite Kriging (one GP per distance term)" if hyper.get("kernel", "").startswith("composite")
                else plan.model_name)
        self._emit("model", f"batch {batch}: {kind} on {len(obs.y)} points ({n_pen} failed, penalised; length scales "
                   f"{', '.join(f'{v:.3g}' for v in hyper['lengthscales'])}, noise {hyper['noise'] or 0.0:.3g}) → "
                   f"{cfg.acquisition} proposes {q} point(s)"
                   f"{f' beside {len(x_pending)} pending' if x_pending is not None else ''}"
                   f"{' at ' + ', '.join(fidelities) if fidelities else ''} "
                   f"in {time.monotonic() - t0:.1f} s", batch=batch, hyperparameters=hyper)
        return unit, cfg.acquisition, hyper, fidelities

    def _without_repeats(self, unit: np.ndarray, points: list[PointRecord], batch: int) -> np.ndarray:
        """Screen the proposals for repeats (:func:`screen_repeats`) and log each decision."""
        spare = sobol_points(self.config.space.dim, 256, seed=self.config.seed + 1, skip=len(points) + batch)
        rows, notes = screen_repeats(unit, points, spare)
        for kind, text in notes:
            if kind == "replicate":
                self._emit("replicate", f"batch {batch}: {text}; it runs as a replicate there, with its own seed "
                           "(the model expects one more seed at that point to pay)", batch=batch)
            else:
                self._emit("repeat", f"batch {batch}: {text}; replaced by a space-filling point",
                           level=logging.WARNING, batch=batch)
        return rows

    def _add_batch(self, store: CampaignStore, batch: int, unit: np.ndarray, source: str | list[str],
                   model: dict | None, fidelities: list[str] | None = None) -> None:
        """Store proposed points (and, in a multi-fidelity campaign, their ``fidelities``) and submit
        them; ``source`` names what proposed them, for the batch or per point."""
        cfg = self.config
        natural = cfg.space.from_unit(unit)
        first = len(store.points())
        seeds = [[simulation_seed(cfg.seed, first + j, i) for i in range(cfg.seeds_per_point)] for j in range(len(unit))]
        ids = store.add_batch(batch, unit, natural, list(cfg.space.names), seeds, source, model, fidelities)
        points = {p.id: p for p in store.points()}
        for pid, row in zip(ids, natural):
            by = points[pid].acquisition
            self._emit("proposed", f"batch {batch}: point {pid} proposed by {by}{_at(points[pid])}: "
                       f"{_fmt_params(cfg.space.as_dict(row))}", batch=batch, point=pid, source=by,
                       params=cfg.space.as_dict(row), **({"fidelity": points[pid].fidelity} if fidelities else {}))
            self._submit(points[pid])

    def _submit(self, p: PointRecord) -> None:
        """Submit the point's simulations that have no outcome yet."""
        cfg = self.config
        pending = [s for s in p.sims if s.status == Status.PENDING]
        if not pending:
            return
        self._outcomes[p.id] = {}
        for s in p.sims:
            if s.status == Status.DONE:
                self._outcomes[p.id][s.index] = CampaignStore(cfg.store).result(p.id, s.index)
            elif s.status == Status.FAILED:
                self._outcomes[p.id][s.index] = None
        base = self.plan.spec(p)
        for s in pending:
            task = SimulationTask(p.id, cfg.simulator, point_spec(base, p.params(), s.seed),
                                  simulation_workdir(cfg.workdir, p.id, s.index))
            self._emit("queued", f"point {p.id} sim {s.index}: queued for {cfg.simulator} (seed {s.seed})",
                       level=logging.DEBUG, point=p.id, sim=s.index, seed=s.seed)
            job = _InFlight(p, s.index, s.seed, task.workdir)
            self._jobs[job.key] = job
            self._scheduler.submit(task, job.key)

    def _record(self, store: CampaignStore, job: _InFlight, done: Finished) -> None:
        """Store one finished simulation; when it is the point's last, the point's metric too."""
        cfg = self.config
        point, index, seed = job.point, job.index, job.seed
        result, failure, wall = done.result, done.failure, done.wall_time
        if result is not None:
            self._engine_walls.append(wall)
        if result is not None:
            self._count_cpu(point.fidelity, result.provenance.cpu_seconds)
        elif math.isfinite(wall):
            self._count_cpu(point.fidelity, wall * cfg.spec.numerics.threads)
        self._sims_finished += 1
        outcomes = self._outcomes[point.id]
        outcomes[index] = result
        metric, error = None, ""
        good = [outcomes[i] for i in sorted(outcomes) if outcomes[i] is not None]
        if len(outcomes) == cfg.seeds_per_point and good:
            try:
                metric = self.metric.evaluate(good, cfg.experiment)
            except CalibraxError as exc:
                error = str(exc)
        if failure is not None:
            self._emit("failed", f"point {point.id} sim {index} ({cfg.simulator}{_at(point)}, seed {seed}) FAILED after "
                       f"{wall:.1f} s [{failure.kind}]: {failure.reason}", level=logging.WARNING, point=point.id,
                       sim=index, seed=seed, kind=failure.kind, reason=failure.reason, wall_s=wall)
            store.add_simulation(point.id, index, seed, None, reason=failure.reason, log_tail=failure.log_tail,
                                 kind=failure.kind, wall_time=wall, metric=metric, metric_error=error)
            return
        store.add_simulation(point.id, index, seed, result, wall_time=wall, metric=metric, metric_error=error)
        for w in result.warnings:
            self._emit("warning", f"point {point.id} sim {index}: {w}", level=logging.WARNING, point=point.id)
        peaks = ", ".join(f"{t:.0f}" for t in result.peak_shear_stress)
        msg = (f"point {point.id} sim {index} done in {wall:.1f} s ({cfg.simulator}{_at(point)}, seed {seed}): "
               f"τ_peak = [{peaks}] Pa")
        if metric is not None:
            f = metric.features
            shown = describe_simulated(f)
            msg += (f", {shown}," if shown else ",") + f" d = {metric.value:.3g} ± {metric.uncertainty:.2g}"
            msg += f" ({noise_text(metric.value, metric.threshold, metric.threshold_rate).split(' (')[0]})"
            if (self._best is None or metric.value < self._best[0]) and self._is_target(point):
                self._best = (metric.value, point.id, point.params())
                self._best_noise = (metric.threshold, metric.threshold_rate)
        elif error:
            msg += f"; metric failed: {error}"
        self._emit("done", f"{msg} | {self._progress_text()} | {self._best_text()}", point=point.id, sim=index, seed=seed, wall_s=wall,
                   peaks_pa=result.peak_shear_stress.tolist(),
                   distance=None if metric is None else metric.value,
                   best_point=None if self._best is None else self._best[1],
                   best_distance=None if self._best is None else self._best[0])

    def _is_target(self, point: PointRecord) -> bool:
        """Whether the point ran at the campaign's target fidelity (always, with one fidelity)."""
        return self.plan.is_target(point)

    def _emit(self, event: str, message: str, level: int = logging.INFO, **data: Any) -> None:
        log.log(level, "%s", message)
        if self.listener is not None:
            self.listener({"event": event, "time": time.time(), "message": message, **data})

    def _best_text(self) -> str:
        if self._best is None:
            return "no best point yet"
        v, pid, params = self._best
        return f"best d = {v:.3g} at point {pid} ({_fmt_params(params)}), {noise_text(v, *self._best_noise)}"


def _at(point: PointRecord) -> str:
    """" at tiny" for a point of a multi-fidelity campaign, "" otherwise."""
    return f" at {point.fidelity}" if point.fidelity else ""


def load_answer(store: CampaignStore) -> Answer | None:
    """The store's last answer, or None."""
    stored = store.answer()
    return Answer.from_dict(stored) if stored else None


def run_campaign(config: CampaignConfig, listener: Callable[[dict[str, Any]], None] | None = None) -> CampaignSummary:
    """Run or resume the campaign of ``config``; ``listener`` gets the progress events."""
    return Campaign(config, listener).run()
