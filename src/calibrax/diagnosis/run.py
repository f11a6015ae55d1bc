"""Running a diagnosis: the DEM design, the scoring, the recalibration and its confirmation.

1. **Where the gap lies.** Replicate seeds at the calibrated point against the experiment, feature
   by feature (:mod:`calibrax.diagnosis.gap`).
2. **Which effect.** The design's simulations, every candidate fitted jointly with the calibrated
   parameters and scored by its Bayes factor against "no effect"
   (:mod:`calibrax.diagnosis.scoring`), on every feature.
3. **How far it shrinks.** The top candidate is fitted again on some feature groups only
   (``fit_on``: the yield locus and the bulk density by default), the recalibrated point
   (calibrated parameters and the effect's magnitude) is simulated with fresh seeds, and the gap
   before and after is compared on the *other* groups (the τ curves' flow and shape by default),
   which played no part in that fit.
4. **The verdict.** A candidate is named only where that confirmation bears it out, and only
   where the model without any effect misfits beyond the noise (on the fit features or on every
   feature); otherwise the
   answer is "none" or "none of the candidates", with the best candidate and why it failed
   (:mod:`calibrax.diagnosis.verdict`).

Simulations run through the study machinery into ``out/design-<hash>.h5`` and
``out/confirm-<hash>.h5`` (one per candidate confirmed), and across fidelities
``out/target-<hash>.h5`` (the target's replicates) and ``out/level-<hash>.h5`` (one per candidate's
point at the target), each named by a hash of its simulations (the confirmation's point
depends only on the design's results), so a killed diagnosis resumes without repeating a finished
simulation, and one whose inputs changed (a resumed campaign's new answer, another ``--fit-on``)
starts a store of its own beside the old; the outcome is written to ``out/diagnosis.json``.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from calibrax.core.studies.simulation_setup import point_spec
from calibrax.core.data.experiment import Experiment
from calibrax.core.running.executor import Executor
from calibrax.core.search.parameters import ParameterSpace
from calibrax.core.sheartest import ShearCellSpec
from calibrax.core.studies.study import StudyCase, run_study
from calibrax.diagnosis import gap as gaps
from calibrax.diagnosis.design import (SEED_BASE, Box, Budget, DesignPoint, design_points, level_point,
                                       reach_points)
from calibrax.diagnosis.effects import Effect, EffectParameter
from calibrax.diagnosis.scoring import (NO_EFFECT, CandidateSpace, Design, Emulator, Ranking, Target, rank,
                                        score_model)
from calibrax.diagnosis.verdict import (MAX_TRIED, NOT_SHRUNK, OUT_OF_REACH, UNSEEN, Confirmation, Verdict,
                                        baseline_test, decide, judge_confirmation)
from calibrax.errors import CalibraxError, ConfigError, DiagnosisError

log = logging.getLogger("calibrax")


@dataclass(frozen=True)
class Calibrated:
    """What a diagnosis starts from: a calibrated model and the experiment it was calibrated on.

    Attributes:
        simulator: the campaign's backend.
        spec: its base spec (calibrated values are set per point).
        space: the calibrated parameters.
        experiment: the measured (or pseudo-) experiment.
        centre: the campaign's recommendation, natural units.
        plausible: {name: (low, high)} of its plausible region (empty: none known).
        metric_gap: the campaign's own verdict at its answer, {``predicted``: d, ``predicted_sd``,
            ``threshold``: the metric's noise threshold} (empty: not known).
        target: a multi-fidelity campaign's target fidelity, the one ``spec`` is ("" at one fidelity).
        cheap: a multi-fidelity campaign's cheapest fidelity and its cell, where the diagnosis runs
            its design (None: every simulation at ``spec``).
    """

    simulator: str
    spec: ShearCellSpec
    space: ParameterSpace
    experiment: Experiment
    centre: dict[str, float]
    plausible: dict[str, tuple[float, float]] = field(default_factory=dict)
    metric_gap: dict[str, float] = field(default_factory=dict)
    target: str = ""
    cheap: tuple[str, ShearCellSpec] | None = None

    def cell(self, fidelity: str) -> ShearCellSpec:
        """The cell a design point of ``fidelity`` runs ("": the target's, the campaign's own)."""
        return self.cheap[1] if fidelity and self.cheap and fidelity == self.cheap[0] else self.spec

    def fidelity_name(self, fidelity: str) -> str:
        """A design point's fidelity in words: its preset's name ("" at one fidelity)."""
        return fidelity or self.target

    @classmethod
    def from_store(cls, path: Path) -> "Calibrated":
        """The campaign of a store: its config, experiment and answer (the recommendation)."""
        from calibrax.core.studies.campaign import load_answer
        from calibrax.core.running.store import CampaignStore

        path = Path(path)
        if not path.is_file():
            raise ConfigError("STORE", f"{path}: no such campaign store (give the .h5 that `calibrax run` wrote)")
        store = CampaignStore(path)
        cfg = store.config()
        experiment = store.experiment()
        answer = load_answer(store)
        if experiment is None or answer is None:
            raise DiagnosisError(f"{path}: the campaign has {'no experiment' if experiment is None else 'no answer yet'}; "
                                 "run it (calibrax run) until it reports an answer, then diagnose it")
        space = ParameterSpace.from_config(cfg["parameters"])
        plausible = {k: tuple(v) for k, v in answer.ranges.items()}
        gap = {"predicted": answer.predicted, "predicted_sd": answer.predicted_sd, "threshold": answer.threshold}
        target, cheap = _fidelities(cfg, path)
        return cls(cfg["simulator"], ShearCellSpec.from_dict(cfg["cell"]), space, experiment, dict(answer.params),
                   plausible, gap, target, cheap)


def _fidelities(cfg: dict[str, Any], path: Path) -> tuple[str, tuple[str, ShearCellSpec] | None]:
    """A campaign's target fidelity and its cheapest one with its cell (``"", None`` at one
    fidelity); a multi-fidelity store written before the cells were recorded is diagnosed at its
    target alone, and the log says so."""
    fidelities = cfg.get("fidelities") or []
    if not fidelities:
        return "", None
    target, cheapest = fidelities[-1]["preset"], fidelities[0]["preset"]
    cells = cfg.get("fidelity_cells") or {}
    if cheapest not in cells:
        log.warning("diagnose: %s records no cell for its cheap fidelity %s (a store written before calibrax "
                    "recorded them): every simulation of the diagnosis runs at the target, %s", path, cheapest, target)
        return target, None
    return target, (cheapest, ShearCellSpec.from_dict(cells[cheapest]))


@dataclass
class Diagnosis:
    """The outcome (all of it JSON-ready through :meth:`to_dict`)."""

    backend: str
    effects: list[str]
    skipped: dict[str, str]
    fit_on: list[str]
    judge_on: list[str]
    features: list[str]
    before: list[gaps.FeatureGap]
    ranking: Ranking
    final: Verdict
    simulations: dict[str, int]
    wall_time: float
    box: dict[str, tuple[float, float]]
    centre: dict[str, float]
    stores: dict[str, str] = field(default_factory=dict)
    metric_gap: dict[str, float] = field(default_factory=dict)
    #: one simulation's seed s.d. per feature at the target (the design emulator's residuals, or
    #: the pure error: :attr:`calibrax.diagnosis.scoring.Emulator.noise_sd`)
    seed_sd: dict[str, float] = field(default_factory=dict)
    #: the features the design emulator misfits beyond the seeds' scatter (:func:`lack_of_fit`)
    lack_of_fit: dict[str, dict[str, float]] = field(default_factory=dict)
    #: per effect parameter, its signature's scale at the target against the cheap level
    #: (a diagnosis across fidelities whose candidates had a point at the target)
    level_scale: dict[str, float] = field(default_factory=dict)
    #: the effect parameters whose signature at the target is read per feature from their point
    #: there, the cheap level's scaled by λ having failed to predict it
    own_signature: list[str] = field(default_factory=list)

    @property
    def verdict(self) -> str:
        """The answer: a confirmed effect's name, ``none`` or ``none of the candidates``."""
        return self.final.name

    @property
    def reason(self) -> str:
        return self.final.reason

    @property
    def recalibrated(self) -> dict[str, Any]:
        """The named effect's recalibration (empty where none was named)."""
        adopted = self.final.adopted
        return dict(adopted.recalibrated) if adopted else {}

    @property
    def after(self) -> list[gaps.FeatureGap]:
        """Every feature's gap at the named effect's recalibration (empty where none was named)."""
        adopted = self.final.adopted
        return list(adopted.after) if adopted else []

    def held_out(self, which: str) -> list[gaps.FeatureGap]:
        rows = self.before if which == "before" else self.after
        return [g for g in rows if g.name in self.judge_on]

    @property
    def gap_before(self) -> float:
        """The held-out gap before: the RMS of the held-out features' z."""
        return gaps.gap_size(self.held_out("before"))

    @property
    def gap_after(self) -> float:
        """The held-out gap after the recalibration; where nothing was recalibrated (no effect
        named), the gap is what it was: :attr:`gap_before`."""
        return gaps.gap_size(self.held_out("after")) if self.after else self.gap_before

    @property
    def shrinkage(self) -> float:
        """1 − gap_after / gap_before: 0 where nothing was recalibrated, NaN where there was no gap."""
        b, a = self.gap_before, self.gap_after
        return 1.0 - a / b if math.isfinite(a) and math.isfinite(b) and b > 0 else math.nan

    def to_dict(self) -> dict[str, Any]:
        def gap_rows(rows: list[gaps.FeatureGap]) -> list[dict[str, Any]]:
            return [dict(asdict(g), z=g.z, stderr=g.stderr, implausible=g.implausible) for g in rows]

        models = [{"name": m.name, "label": m.label, "probability": m.probability, "log_evidence": m.log_evidence,
                   "best_effect": m.best_effect, "effect_mean": m.effect_mean,
                   "effect_interval": {k: list(v) for k, v in m.effect_interval.items()},
                   "max_abs_z": m.max_abs_z, "z": dict(zip(self.ranking.names, map(float, m.z))),
                   "prior": list(m.prior_text)} for m in self.ranking.models]
        final = self.final.to_dict()
        for c, confirmation in zip(final["confirmations"], self.final.confirmations):
            c["after"] = gap_rows(list(confirmation.after))
        return {"backend": self.backend, "effects": self.effects, "skipped": self.skipped, "fit_on": self.fit_on,
                "judge_on": self.judge_on, "features": self.features, **final,
                "design_verdict": {"verdict": self.ranking.verdict, "reason": self.ranking.reason,
                                   "unexplained": list(self.ranking.unexplained)}, "models": models,
                "before": gap_rows(self.before),
                "after": gap_rows(self.after), "recalibrated": self.recalibrated,
                "gap_before": self.gap_before, "gap_after": self.gap_after,
                "shrinkage": self.shrinkage, "simulations": self.simulations, "wall_time": self.wall_time,
                "box": {k: list(v) for k, v in self.box.items()}, "centre": self.centre, "stores": self.stores,
                "metric_gap": self.metric_gap, "seed_sd": self.seed_sd, "lack_of_fit": self.lack_of_fit,
                "level_scale": self.level_scale, "own_signature": self.own_signature}


def candidate_spaces(effects: list[Effect], experiment: Experiment) -> list[CandidateSpace]:
    """Each effect's parameters and priors, for the scoring."""
    out = []
    for e in effects:
        priors = e.prior(experiment)
        out.append(CandidateSpace(e.name, e.label, tuple(p.name for p in e.parameters), tuple(p.off for p in e.parameters),
                                  tuple(p.high for p in e.parameters), tuple(priors[p.name] for p in e.parameters),
                                  tuple(f"{p.name}: {priors[p.name].describe()}" for p in e.parameters)))
    return out


def usable_effects(effects: list[Effect], capabilities: frozenset[str], backend: str,
                   asked: bool) -> tuple[list[Effect], dict[str, str]]:
    """The effects the backend can model; one it cannot is an error when the user named it, and is
    skipped (with the reason) when it came from the default list."""
    keep, skipped = [], {}
    for e in effects:
        if e.capability in capabilities:
            keep.append(e)
        elif asked:
            raise ConfigError("--effects", f"{backend} cannot model {e.name} (needs {e.capability!r}); "
                              f"it models {sorted(capabilities)}; choose another --backend or drop it")
        else:
            skipped[e.name] = f"{backend} cannot model it (needs {e.capability!r})"
    if not keep:
        raise ConfigError("--effects", f"{backend} can model none of the candidate effects")
    return keep, skipped


def design_case(calibrated: Calibrated, backend: str, point: DesignPoint, effects: dict[str, Effect]) -> StudyCase:
    spec = point_spec(calibrated.cell(point.fidelity), point.params, 0)
    if point.effect is not None:
        spec = effects[point.effect].apply(spec, point.effect_values)
    coords = dict(point.params, **point.effect_values)
    return StudyCase(point.label, backend, spec.validate(), point.seeds, coords)


def stage_progress(stage: str):
    started = time.monotonic()

    def report(done: int, total: int) -> None:
        elapsed = time.monotonic() - started
        log.info("diagnose %s: %d of %d simulations done, %d to go (%.0f s)", stage, done, total, total - done, elapsed)
    return report


def _design_arrays(points: list[DesignPoint], features: list[list[dict[str, float]]], box: Box,
                   params: dict[str, EffectParameter]
                   ) -> tuple[np.ndarray, np.ndarray, list[dict[str, float]], list[int], np.ndarray]:
    """Per simulated test (``features[i]``: those of design point i's seeds): the calibrated
    parameters on [−1, 1] over the box, shape (n, d), every effect parameter as a fraction of its
    range (0: off), shape (n, K) in the order of ``params``, its features, the index of its
    design point, and whether it ran at the target fidelity, shape (n,) of bool."""
    columns = list(params)
    unit, eff, feats, which, at_target = [], [], [], [], []
    for i, (pt, point_features) in enumerate(zip(points, features)):
        scaled = box.scaled(np.array([[pt.params[n] for n in box.space.names]]))[0]
        fractions = [float(params[c].scaled(pt.effect_values[c])) if c in pt.effect_values else 0.0 for c in columns]
        for f in point_features:
            unit.append(scaled)
            eff.append(fractions)
            feats.append(f)
            which.append(i)
            at_target.append(not pt.fidelity)
    return (np.array(unit).reshape(len(unit), box.space.dim), np.array(eff, dtype=float).reshape(len(unit), len(columns)),
            feats, which, np.array(at_target, dtype=bool))


def diagnose(calibrated: Calibrated, effects: list[Effect], out: Path, executor: Executor, *, backend: str | None = None,
             budget: Budget | None = None, fit_on: tuple[str, ...] | str = gaps.DEFAULT_FIT, seed: int = 0,
             asked: bool = False,
             capabilities: frozenset[str] | None = None) -> Diagnosis:
    """Run (or resume) a diagnosis into ``out`` and return it (see the module docstring).

    Args:
        calibrated: the calibrated campaign.
        effects: the candidate effects.
        out: the folder of its stores, summary and figures.
        executor: runs the simulations of both studies; shut down at the end.
        backend: the diagnosing simulator (default: the campaign's).
        budget: how many simulations go where (default :class:`Budget`).
        fit_on: the feature groups the recalibration is fitted to (:data:`~calibrax.diagnosis.gap.GROUPS`);
            the others judge it.
        asked: whether the user named the effects (an effect the backend cannot model is then an
            error, not skipped).
        capabilities: the backend's (default: asked of the backend).
    """
    from calibrax.core.registry import get_manager

    fit_on = gaps.parse_groups(fit_on)
    started = time.monotonic()
    backend = backend or calibrated.simulator
    if capabilities is None:
        capabilities = frozenset(get_manager().create("simulator", backend).capabilities())
    effects, skipped = usable_effects(effects, capabilities, backend, asked)
    cheap = calibrated.cheap[0] if calibrated.cheap else ""
    budget = budget or (Budget.across_fidelities() if cheap else Budget())
    if cheap and budget.target_replicates < 1:
        raise ConfigError("--budget", f"a diagnosis across fidelities needs at least one replicate at the target "
                          f"{calibrated.target} (where the gap is measured); the budget gives none")
    names_seen = [p.name for e in effects for p in e.parameters]
    effect_params = {p.name: p for e in effects for p in e.parameters}
    if len(set(names_seen)) != len(names_seen):
        raise ConfigError("--effects", f"two candidates add a parameter of the same name: {names_seen}")
    box = Box.around(calibrated.space, calibrated.centre, calibrated.plausible)
    points = design_points(box, effects, budget, seed, cheap)
    by_name = {e.name: e for e in effects}
    cases = [design_case(calibrated, backend, p, by_name) for p in points]   # every spec is checked before a file is made
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    log.info("diagnose: %d candidate effects (%s) on %s: a design of %d simulations, then up to %d to confirm each "
             "candidate's recalibration where the baseline misfits (up to %d candidates, the next only where the "
             "one before is refuted)", len(effects), ", ".join(e.name for e in effects), backend,
             sum(len(p.seeds) for p in points), budget.confirm, MAX_TRIED)
    if cheap:
        log.info("diagnose: across fidelities: the design at %s but for %d replicates at the target %s, where the gap "
                 "is measured and each recalibration confirmed; the emulator reads the target through the shift "
                 "between them", cheap, budget.target_replicates, calibrated.target)
    try:
        stores_run: dict[str, str] = {}
        # across fidelities the target's replicates keep a store of their own: a change to the cheap
        # design then reruns none of the costly tests (1.3 CPU-hours at converged)
        costly = [i for i, p in enumerate(points) if cheap and not p.fidelity]
        rest = [i for i in range(len(points)) if i not in costly]
        by_index = dict(zip(costly, _run_stage(out, "target", [cases[i] for i in costly], executor, "diagnose",
                                               stores_run, key="target"))) if costly else {}
        by_index.update(zip(rest, _run_stage(out, "design", [cases[i] for i in rest], executor, "diagnose",
                                             stores_run, key="design")))
        outcomes = [by_index[i] for i in range(len(points))]
        peak_window = calibrated.spec.procedure.peak_window
        measured, spaces = gaps.measured(calibrated.experiment, peak_window), candidate_spaces(effects, calibrated.experiment)

        # simulations at the target that were run as a confirmation and also read as design (a refuted
        # refit of the model without an effect); counted once, as confirmations
        also_design: list[tuple[DesignPoint, Any]] = []

        def scored_on(box: Box, points: list[DesignPoint], outcomes: list[Any]) -> _Scored:
            points = points + [p for p, _ in also_design]
            outcomes = outcomes + [o for _, o in also_design]
            return score_design(measured, spaces, points, [_features(o, peak_window) for o in outcomes],
                                sum(len(o.failures) for o in outcomes), box, effect_params, seed)

        scored = scored_on(box, points, outcomes)
        top = next((m for m in scored.ranking.models if m.name != NO_EFFECT), None)
        wider = box.reach(top.best_unit) if top is not None and scored.ranking.verdict != NO_EFFECT else None
        if wider is not None:
            extra = reach_points(box, wider, by_name[top.name], budget, seed, cheap)
            log.info("diagnose: %s's best fit sits at the design box's edge (%s): the box reaches past it, to %s, with "
                     "%d more simulations", top.label, _box_words(box), _box_words(wider), len(extra))
            extra_cases = [design_case(calibrated, backend, p, by_name) for p in extra]
            outcomes = outcomes + _run_stage(out, "reach", extra_cases, executor, "diagnose", stores_run,
                                             key="reach")
            points, box = points + extra, wider
            scored = scored_on(box, points, outcomes)
        names = scored.design.names
        judge = [n for n in names if gaps.group_of(n) not in fit_on]
        done: dict[str, Any] = {"n": 0, "engine": 0.0, "cpu": 0.0, "stores": []}

        def simulate(point: DesignPoint, effect: Effect | None) -> Any:
            cases = [design_case(calibrated, backend, point, {effect.name: effect} if effect is not None else {})]
            store = study_store(out, "confirm", cases)
            outcomes = run_study(cases, store, executor, out / "runs" / store.stem, "confirm",
                                 stage_progress(f"confirmation of {effect.name if effect is not None else NO_EFFECT}"),
                                 shutdown=False)
            done["n"] += len(point.seeds)
            done["engine"] += sum(r.provenance.wall_time for r in outcomes[0].good)
            done["cpu"] += sum(r.provenance.cpu_seconds for r in outcomes[0].good)
            done["stores"].append(store.name)
            return outcomes[0]

        refit = None
        baseline_fits = bool(cheap) and not baseline_test(scored.design, scored.target, tuple(fit_on), seed).misfits
        if judge and baseline_fits:
            refit, refit_point, refit_outcome = refit_at_target(scored, box, tuple(fit_on), budget, seed, simulate,
                                                                peak_window)
            if refit is not None and not refit.stands and refit_outcome is not None:
                # the refuted refit is the target's own response to the calibrated parameters: the design reads it
                also_design.append((refit_point, refit_outcome))
                scored = scored_on(box, points, outcomes)
        # a level point serves a candidate that may be tried: not where "no effect" is already settled
        settled = refit.stands if refit is not None else bool(judge) and baseline_fits
        if cheap and not settled:
            scored, points, outcomes = _levelled(scored, scored_on, box, effects, budget, seed, points, outcomes,
                                                 lambda pt: design_case(calibrated, backend, pt, by_name),
                                                 lambda cases: _run_stage(out, "level", cases, executor,
                                                                          "diagnose", stores_run))
        names = scored.design.names
        judge = [n for n in names if gaps.group_of(n) not in fit_on]

        if not judge:
            log.info("diagnose: every feature of the experiment (%s) is in the groups the recalibration would fit "
                     "(%s): none is left to judge it on, so no recalibration is run", ", ".join(names), ", ".join(fit_on))
        final = judged_verdict(scored, box, by_name, tuple(fit_on), budget, seed,
                               (lambda point, effect: _features(simulate(point, effect), peak_window)) if judge else None,
                               refit)
        log.info("diagnose: verdict %r: %s", final.name, final.reason)
    finally:
        executor.shutdown()
    by_level = cost_by_fidelity(calibrated, points, outcomes, done)
    engine = sum(row["engine_seconds"] for row in by_level.values())
    cpu = sum(row["cpu_seconds"] for row in by_level.values())
    sims = {"engine_seconds": int(round(engine)), "cpu_seconds": int(round(cpu)), "design": int(sum(len(p.seeds) for p in points)),
            "design_failed": int(scored.failed),
            "confirm": int(done["n"]), "total": int(sum(len(p.seeds) for p in points) + done["n"])}
    if cheap:
        sims["by_fidelity"] = {k: {key: int(round(v)) for key, v in row.items()} for k, row in by_level.items()}
    stores = {**stores_run, **confirm_stores(final, done["stores"])}
    result = Diagnosis(backend, [e.name for e in effects], skipped, list(fit_on), judge, list(names), scored.before,
                       scored.ranking, final, sims, time.monotonic() - started,
                       {n: (float(box.low[i]), float(box.high[i])) for i, n in enumerate(box.space.names)},
                       dict(calibrated.centre), stores, dict(calibrated.metric_gap), dict(scored.seed_sd),
                       lack_of_fit(scored.emulator, names), _level_scale(scored.emulator),
                       _own_signature(scored.emulator))
    write_json(out / "diagnosis.json", result.to_dict())
    return result


def _run_stage(out: Path, kind: str, cases: list[StudyCase], executor: Executor, label: str,
               stores: dict[str, str], key: str | None = None) -> list[Any]:
    """Run one more study of the diagnosis into its own store (``kind-<hash>.h5``, recorded in
    ``stores`` under ``key``, default ``kind-<first case's label>``) and return its outcomes."""
    store = study_store(out, kind, cases)
    outcomes = run_study(cases, store, executor, out / "runs" / store.stem, label, stage_progress(kind),
                         shutdown=False)
    stores[key or f"{kind}-{cases[0].label.split(' ')[0]}"] = store.name
    return outcomes


def _levelled(scored: "_Scored", scored_on: Callable[[Box, list[DesignPoint], list[Any]], "_Scored"], box: Box, effects: list[Effect],
              budget: Budget, seed: int, points: list[DesignPoint], outcomes: list[Any],
              case_of: Callable[[DesignPoint], StudyCase], run: Callable[[list[StudyCase]], list[Any]]
              ) -> tuple["_Scored", list[DesignPoint], list[Any]]:
    """Across fidelities: the candidate ranked first gets one point at the target
    (:func:`~calibrax.diagnosis.design.level_point`), which gives its signature's scale there, and
    the design is scored again; where another candidate then ranks first, it gets its own, up to
    ``budget.level_points`` candidates."""
    levelled: set[str] = set()
    while len(levelled) < budget.level_points:
        top = next((m for m in scored.ranking.models if m.name != NO_EFFECT), None)
        if top is None or top.name in levelled:
            break
        index = next(i for i, e in enumerate(effects) if e.name == top.name)
        point = level_point(box, effects[index], index, seed)
        log.info("diagnose: %s ranks first; one simulation at the target with %s gives its signature's size there",
                 effects[index].label, ", ".join(f"{k} = {v:.4g}" for k, v in point.effect_values.items()))
        outcomes = outcomes + run([case_of(point)])
        points = points + [point]
        levelled.add(top.name)
        scored = scored_on(box, points, outcomes)
        found = level_words(_level_scale(scored.emulator), _own_signature(scored.emulator))
        if found:
            log.info("diagnose: at the target, %s", found)
    return scored, points, outcomes


def _box_words(box: Box) -> str:
    return ", ".join(f"{n} {lo:.4g} to {hi:.4g}" for n, lo, hi in zip(box.space.names, box.low, box.high))


def cost_by_fidelity(calibrated: Calibrated, points: list[DesignPoint], outcomes: list[Any],
                     confirmed: dict[str, Any]) -> dict[str, dict[str, float]]:
    """{fidelity: {``simulations``, ``engine_seconds`` (wall), ``cpu_seconds``}} of a diagnosis:
    the design's simulations at each level, and the confirmations at the target (one row at one
    fidelity); the diagnosis's totals are their sums."""
    keys = ("simulations", "engine_seconds", "cpu_seconds")
    out: dict[str, dict[str, float]] = {name: dict.fromkeys(keys, 0.0)   # cheapest first
                                        for name in (calibrated.cheap[0] if calibrated.cheap else "", calibrated.target)
                                        if name}
    for point, outcome in zip(points, outcomes):
        row = out.setdefault(calibrated.fidelity_name(point.fidelity), dict.fromkeys(keys, 0.0))
        row["simulations"] += len(point.seeds)
        row["engine_seconds"] += sum(r.provenance.wall_time for r in outcome.good)
        row["cpu_seconds"] += sum(r.provenance.cpu_seconds for r in outcome.good)
    row = out.setdefault(calibrated.target, dict.fromkeys(keys, 0.0))
    row["simulations"] += confirmed["n"]
    row["engine_seconds"] += confirmed["engine"]
    row["cpu_seconds"] += confirmed["cpu"]
    return out


def study_store(out: Path, kind: str, cases: list[StudyCase]) -> Path:
    """The store of a diagnosis's study: ``kind-<hash of its cases>.h5`` (``kind.h5`` where an
    earlier version wrote that name for the same cases)."""
    from calibrax.core.running.store import CampaignStore
    from calibrax.core.studies.study import study_hash

    digest = study_hash(cases)
    legacy = out / f"{kind}.h5"
    try:
        if CampaignStore(legacy).check(digest):
            return legacy
    except CalibraxError:
        pass
    return out / f"{kind}-{digest[:8]}.h5"


@dataclass
class _Scored:
    """The design read and scored: what the recalibration and the summary need."""

    design: Design
    target: Target
    spaces: list[CandidateSpace]
    ranking: Ranking
    experiment: list[dict[str, float]]
    seed_sd: dict[str, float]
    before: list[gaps.FeatureGap]
    failed: int
    emulator: Emulator


def score_design(experiment: list[dict[str, float]], spaces: list[CandidateSpace], points: list[DesignPoint],
                 features: list[list[dict[str, float]]], failed: int, box: Box,
                 effect_params: dict[str, EffectParameter], seed: int) -> _Scored:
    """Rank the candidates on the design's features and measure the gap at the calibrated point
    (design point 0). Numbers only: ``experiment`` holds each replicate's diagnosis features,
    ``features[i]`` those of design point i's finished simulations, ``failed`` counts the rest."""
    unit, eff, feats, which, at_target = _design_arrays(points, features, box, effect_params)
    if any(p.fidelity for p in points) and not at_target.any():
        raise DiagnosisError(f"none of the {len(points[0].seeds)} replicates at the target fidelity finished, and the "
                             "gap is measured there; see the design's failures and run the diagnosis again")
    names = gaps.usable(gaps.candidate_names(experiment), experiment, feats)
    if len(names) < 2:
        raise DiagnosisError(f"only {len(names)} feature(s) in common between the experiment and the simulations "
                             f"({list(names)}); the diagnosis needs at least two")
    rows = [i for i, f in enumerate(feats) if all(math.isfinite(f.get(n, math.nan)) for n in names)]
    y = np.array([[feats[i][n] for n in names] for i in rows])
    design = Design(unit[rows], eff[rows], tuple(effect_params), y, names,
                    at_target[rows] if not at_target.all() else None, np.asarray(which)[rows])
    target = _target(experiment, names)
    try:
        emulator = Emulator.fit(design)
    except ValueError as exc:
        raise DiagnosisError(f"{exc} ({failed} of the design's simulations failed); give a larger --budget") from None
    ranking = rank(target, design, spaces, seed, emulator)
    seed_sd = dict(zip(names, map(float, emulator.noise_sd)))
    centre_sims = [feats[i] for i, w in enumerate(which) if w == 0]
    before = gaps.feature_gaps(centre_sims, experiment, names, seed_sd)
    return _Scored(design, target, spaces, ranking, experiment, seed_sd, before, failed, emulator)


def _level_scale(emulator: Emulator) -> dict[str, float]:
    """{effect parameter: λ} of the columns a target simulation measured and λ carries (empty: none)."""
    if emulator.level_scale is None:
        return {}
    own = _own_signature(emulator)
    return {c: float(s) for c, s in zip(emulator.effect_columns, emulator.level_scale) if s != 1.0 and c not in own}


def _own_signature(emulator: Emulator) -> list[str]:
    """The effect parameters whose signature at the target is read per feature from their point there."""
    if emulator.own_signature is None:
        return []
    return [c for c, own in zip(emulator.effect_columns, emulator.own_signature) if own]


def level_words(scales: dict[str, float], own: list[str]) -> str:
    """What the points at the target showed of the effects' signatures there, in words ("": nothing)."""
    return "; ".join([f"{c} acts as {s:.3g} × itself at the cheap level" for c, s in scales.items()]
                     + [f"{c}'s signature differs from the cheap level's in shape, not only in size, so it is read "
                        "per feature from its point there" for c in own])


def lack_of_fit(emulator: Emulator, names: tuple[str, ...]) -> dict[str, dict[str, float]]:
    """The features the design emulator misfits beyond its seeds' scatter, a finding of its own:
    {feature: {``residual_sd``, ``pure_error_sd``, ``p``}} (empty where it fits). Such a feature's
    gap is judged by the pure error, and its misfit enters the likelihood as the emulator's own
    error (:attr:`calibrax.diagnosis.scoring.Emulator.discrepancy_sd`)."""
    out = {}
    for j in np.flatnonzero(emulator.misfit):
        out[names[j]] = {"residual_sd": float(emulator.sd[j]), "pure_error_sd": float(emulator.pure_sd[j]),
                         "p": float(emulator.lack_of_fit_p[j]), "pure_error_dof": int(emulator.pure_dof)}
    return out


def _target(experiment: list[dict[str, float]], names: tuple[str, ...]) -> Target:
    v = np.array([[e[n] for n in names] for e in experiment])
    sd = v.std(axis=0, ddof=1) if v.shape[0] > 1 else np.full(len(names), math.nan)
    return Target(v.mean(axis=0), sd, v.shape[0])


#: the words for the model without an effect where it is recalibrated and confirmed like a candidate
NO_EFFECT_LABEL = "the calibrated parameters alone"


def recalibration(box: Box, effect: Effect | None, scored: _Scored, fit_on: tuple[str, ...], budget: Budget,
                  seed: int) -> tuple[dict[str, Any], DesignPoint]:
    """Fit the top effect (None: no effect, the calibrated parameters alone) on the ``fit_on``
    groups: the recalibration's record and the point (with its confirmation seeds) that simulates it."""
    design, target, spaces = scored.design, scored.target, scored.spaces
    keep = [j for j, n in enumerate(design.names) if gaps.group_of(n) in fit_on]
    if not keep:
        raise DiagnosisError(f"none of the features is in the groups {list(fit_on)} the recalibration is fitted to "
                             f"(features: {list(design.names)}); choose other --fit-on groups")
    sub = design.only(keep)
    sub_target = Target(target.mean[keep], target.sd[keep], target.n)
    space = next(s for s in spaces if s.name == effect.name) if effect is not None else None
    fit = score_model(sub_target, Emulator.fit(sub), space, seed)
    name, label = (effect.name, effect.label) if effect is not None else (NO_EFFECT, NO_EFFECT_LABEL)
    # the posterior mean, not the best fit: a few fit features leave a ridge (more wall friction, less
    # μs) whose best point sits in a corner of the box, where the emulator extrapolates (measured at
    # quick: the best fit's held-out gap grew from RMS z 3.0 to 5.5)
    params = dict(zip(box.space.names, map(float, box.natural(fit.mean_unit[None])[0])))
    values = dict(fit.effect_mean)
    recal = {"effect": name, "label": label, "params": params, "effect_values": values,
             "effect_mean": fit.effect_mean, "effect_interval": {k: list(v) for k, v in fit.effect_interval.items()},
             "best_fit": {**dict(zip(box.space.names, map(float, box.natural(fit.best_unit[None])[0]))),
                          **fit.best_effect},
             "fitted_on": list(sub.names)}
    log.info("diagnose: recalibrated with %s on %s: %s", label, "+".join(fit_on),
             ", ".join([f"{k} = {v:.4g}" for k, v in params.items()]
                       + [f"{k} = {v:.4g} (95 % interval {fit.effect_interval[k][0]:.3g} to {fit.effect_interval[k][1]:.3g})"
                          for k, v in values.items()]))
    point = DesignPoint("recalibrated", params, effect.name if effect is not None else None, values,
                        tuple(SEED_BASE + 1000 * seed + 900 + i for i in range(budget.confirm)))
    return recal, point


def refit_at_target(scored: _Scored, box: Box, fit_on: tuple[str, ...], budget: Budget, seed: int,
                    simulate: Callable[[DesignPoint, Effect | None], Any], peak_window: float
                    ) -> tuple[Confirmation | None, DesignPoint | None, Any]:
    """Across fidelities, where the model without an effect fits within the noise through the
    design's emulator: its refit, simulated at the target with fresh seeds and judged as a
    candidate's recalibration is (:func:`calibrax.diagnosis.verdict.judge_confirmation`), with the
    point and the simulations' outcome; (None, None, None) where the target's replicates show no
    gap beyond the seed noise (nothing to refit). A refit that the emulator itself predicts cannot
    close the gap the target measured (:func:`anchored_refit`, beyond the seed noise's limit over
    every feature) is refuted without a simulation (``out of reach``; no point, no outcome). The emulator's response to the calibrated
    parameters is the cheap level's, so its "the refit closes the gap" is a claim about the target
    that only the target can bear out (measured at `converged` with a hidden wall friction of 0.3:
    docs/explanation/diagnosis.md, "Across fidelities")."""
    if gaps.gap_size(scored.before) <= gaps.noise_gap_limit(len(scored.before)):
        return None, None, None
    recal, point = recalibration(box, None, scored, fit_on, budget, seed)
    reached = anchored_refit(scored, box, point)
    reach, limit = gaps.gap_size(reached), gaps.noise_gap_limit(len(reached))
    if reach > limit:
        refuted = Confirmation(NO_EFFECT, recal["label"], OUT_OF_REACH, gaps.gap_size(scored.before), reach, limit,
                               math.nan, math.nan, recalibrated=recal, after=tuple(reached))
        log.info("diagnose: the model without an effect, refitted, fits within the noise through the design's "
                 "emulator, but %s", refuted.words())
        return refuted, None, None
    log.info("diagnose: the model without an effect, refitted, fits within the noise through the design's emulator, "
             "whose response to the calibrated parameters is the cheap level's; its refit is simulated at the target")
    outcome = simulate(point, None)
    judge = tuple(n for n in scored.design.names if gaps.group_of(n) not in fit_on)
    confirmation = _judged(scored, box, None, recal, point, _features(outcome, peak_window), judge, seed)
    if confirmation.outcome == UNSEEN:
        # a candidate the held-out features cannot see is not refuted by them; the refit's claim is
        # that it closes the gap they show, and a gap left beyond the noise, unshrunk, refutes that
        confirmation = dataclasses.replace(confirmation, outcome=NOT_SHRUNK)
    log.info("diagnose: at the target, %s", confirmation.words())
    return confirmation, point, outcome


def anchored_refit(scored: _Scored, box: Box, point: DesignPoint) -> list[gaps.FeatureGap]:
    """Every feature's gap at a refit without an effect as the design emulator predicts it from
    what the target measured: the calibrated point's simulated means (the target's replicates)
    moved by the emulator's change from the calibrated point to ``point``, judged by the same
    standard errors. The emulator's misfit elsewhere in the design (a rough wall's peak τ/σ at
    `tiny`) widens its likelihood everywhere, and a baseline that "fits" through it may sit where
    the target has already measured the gap: at `converged` with a wall friction of 0.3 the refit
    moved μs from 0.350 to 0.353, where the bulk density stood 4.3 standard errors off."""
    move = predicted_move(scored, box, None, point)
    return [dataclasses.replace(g, sim_mean=g.sim_mean + float(move[j])) for j, g in enumerate(scored.before)]


def _features(outcome: Any, peak_window: float) -> list[dict[str, float]]:
    """The diagnosis features of one study case's finished simulations."""
    return gaps.simulated(outcome.good, peak_window)


def _judged(scored: _Scored, box: Box, effect: Effect | None, recal: dict[str, Any], point: DesignPoint,
            sims: list[dict[str, float]], judge: tuple[str, ...], seed: int) -> Confirmation:
    """One recalibration's confirmation judged on the held-out features ``judge``."""
    names = scored.design.names
    index = [names.index(n) for n in judge]
    after = gaps.feature_gaps(sims, scored.experiment, names, scored.seed_sd)
    return judge_confirmation(recal["effect"], recal["label"], scored.before, after, judge,
                              scored.emulator.corr[np.ix_(index, index)], len(sims), recal, seed,
                              predicted_move(scored, box, effect, point)[index])


def predicted_move(scored: _Scored, box: Box, effect: Effect | None, point: DesignPoint) -> np.ndarray:
    """The design emulator's change of every feature from the calibrated point without any effect
    to ``point`` with ``effect`` at its values (None: no effect), natural units, shape (F,)."""
    em = scored.emulator
    centre = box.scaled(np.asarray(box.centre, dtype=float)[None])[0]
    unit = box.scaled(np.array([[point.params[n] for n in box.space.names]]))[0]
    effects = np.zeros(len(em.effect_columns))
    for p in (effect.parameters if effect is not None else ()):
        if p.name in em.effect_columns and p.name in point.effect_values:
            effects[em.effect_columns.index(p.name)] = float(p.scaled(point.effect_values[p.name]))
    mu, _ = em.predict(np.array([unit, centre]), np.array([effects, np.zeros_like(effects)]))
    return mu[0] - mu[1]


def judged_verdict(scored: _Scored, box: Box, effects: dict[str, Effect], fit_on: tuple[str, ...], budget: Budget,
                   seed: int, simulate: Callable[[DesignPoint, Effect], list[dict[str, float]]] | None,
                   refit: Confirmation | None = None) -> Verdict:
    """The verdict (:func:`calibrax.diagnosis.verdict.decide`): each candidate to confirm is
    recalibrated on the ``fit_on`` groups, ``simulate`` gives its fresh seeds' features (the
    DEM's, or the benchmark's truth emulator's), and the other groups judge it. ``simulate`` None:
    no feature is held out, so nothing is confirmed and the design's ranking stands. ``refit``:
    the model without an effect's refit confirmed at the target (:func:`refit_at_target`)."""
    names = scored.design.names
    judge = tuple(n for n in names if gaps.group_of(n) not in fit_on)
    if simulate is None or not judge:
        return decide(scored.ranking, None, None)
    if budget.confirm < 1:
        return decide(scored.ranking, None, None, "the budget gives no confirmation simulations")

    def confirm(name: str) -> Confirmation:
        recal, point = recalibration(box, effects[name], scored, fit_on, budget, seed)
        return _judged(scored, box, effects[name], recal, point, simulate(point, effects[name]), judge, seed)

    return decide(scored.ranking, baseline_test(scored.design, scored.target, fit_on, seed), confirm, refit=refit)


def confirm_stores(final: Verdict, stores: list[str]) -> dict[str, str]:
    """The confirmation stores by role: ``confirm`` the named effect's (where one was named),
    ``confirm-<effect>`` every other candidate's that was confirmed in turn."""
    out = {}
    for c, store in zip(final.confirmations, stores):
        out["confirm" if final.adopted is c else f"confirm-{c.effect}"] = store
    return out


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write atomically: a killed write leaves the former file."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=1, default=_plain))
    tmp.replace(path)


def _plain(v: Any) -> Any:
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    raise TypeError(type(v))
