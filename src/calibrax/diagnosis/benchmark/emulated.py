"""The emulator level: many cases in minutes, with a response surface of a real DEM design
standing in for the simulator.

**The truth emulator.** Each diagnosis feature is fitted by least squares to the shipped design
(``data/design-tiny.json``, made by :func:`export_design`; see its ``about``) on a basis richer
than the diagnosis's own emulator: ``[1, u, u_i u_j, g_k, g_k², g_k u_i]`` with u the calibrated
parameters on [−1, 1] over the model's box and g_k each effect parameter as a fraction of its
range, rolling friction (the unlisted effect) included. A simulated test is its mean plus a draw
of the residuals' covariance (the design's seed noise and lack of fit). Two effects at once add
their terms: an assumption the DEM level does not make.

**A case** is three replicates drawn at the truth (parameters inside the box, hidden effects)
with :class:`MeasurementNoise` on top, as relative noise per feature. **Its diagnosis** is
:func:`calibrax.diagnosis.run.score_design` and :func:`~calibrax.diagnosis.run.recalibration` on
a design drawn afresh from the truth emulator at the model's design points, the same code that
scores a DEM design; the confirmation and the oracle are draws too.

What this level cannot show: effects the design did not vary, a truth backend other than the
design's, and the diagnosis's own emulator being wrong in ways the truth emulator is not.
"""

from __future__ import annotations

import json
import logging
import math
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from calibrax.diagnosis import gap as gaps
from calibrax.diagnosis.benchmark.cases import (CLASS_MISMATCH, CLASS_MISMATCH_LISTED, CLASS_MIXED, CLASS_NONE,
                                                CLASS_UNLISTED, MAGNITUDES, OTHER_CLASSES,
                                                ROLLING_FRICTION_TRUTH, CaseLabel, MeasurementNoise, RollingFriction,
                                                expected_answer, listed_and_unlisted, opaque_ids)
from calibrax.diagnosis.benchmark.model import BenchmarkModel
from calibrax.diagnosis.benchmark.scores import Answer
from calibrax.diagnosis.effects import EffectParameter
from calibrax.diagnosis.scoring import NO_EFFECT, NONE_OF_THEM
from calibrax.errors import ConfigError

DEFAULT_DESIGN = Path(__file__).parent / "data" / "design-tiny.json"
#: the diagnosis features the emulator can predict (those of them a design has: ``TruthEmulator.features``)
FEATURES = tuple(n for g in gaps.GROUPS.values() for n in g)


def effect_parameters(model: BenchmarkModel, unlisted: bool = True) -> dict[str, EffectParameter]:
    """Every effect parameter the design varies: every registered effect's and the unlisted
    rolling friction's (the benchmark's design), or only the model's candidates'."""
    if not unlisted:
        return {e.parameters[0].name: e.parameters[0] for e in model.effects()}
    out = {e.parameters[0].name: e.parameters[0] for e in model.effects_all()}
    rf = RollingFriction(off=model.spec.material.rolling_friction)
    out[rf.parameters[0].name] = rf.parameters[0]
    return out


#: rows without any effect needed to estimate the seed noise at the model's point from them alone
PLAIN_ROWS_MIN = 6


def _basis(u: np.ndarray, g: np.ndarray) -> np.ndarray:
    n, d = u.shape
    cols = [np.ones((n, 1)), u, np.column_stack([u[:, i] * u[:, j] for i in range(d) for j in range(i, d)]), g, g ** 2]
    cols += [g[:, [k]] * u for k in range(g.shape[1])]
    return np.hstack(cols)


@dataclass
class TruthEmulator:
    """The response surface of the design (see the module docstring)."""

    model: BenchmarkModel
    columns: tuple[str, ...]
    params: dict[str, EffectParameter]
    coef: np.ndarray          # (p, F)
    cov: np.ndarray           # (F, F) one simulation's residual covariance, all rows
    n_rows: int
    plain_cov: np.ndarray | None = None   # (F, F) the same over the rows without any effect (the seed noise
                                          # at the model's point; the effects' lack of fit left out)
    features: tuple[str, ...] = FEATURES  # the F features: those of FEATURES that every row of the design has
    #: each procedure mismatch's offset of the features' means, shape (F,) (see :meth:`fit`)
    mismatch: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def fit(cls, model: BenchmarkModel, rows: list[dict[str, Any]], unlisted: bool = True) -> "TruthEmulator":
        """Fit to a design's rows; ``unlisted``: they include the rolling-friction block and every
        registered effect (the benchmark's design), else only the model's candidates (a diagnosis design)."""
        mismatched = [r for r in rows if r.get("mismatch")]
        rows = [r for r in rows if not r.get("mismatch")]
        params = effect_parameters(model, unlisted)
        columns = tuple(params)
        unvaried = [c for c in columns if not any(abs(r["effects"].get(c, params[c].off) - params[c].off) > 0
                                                  for r in rows)]
        if unvaried:
            raise ConfigError("--design", f"the design varies none of {unvaried}: it was made for other effects "
                              "than the model's candidates; remake it (python benchmarks/diagnosis.py make-design)")
        u, g = cls._inputs(model, params, columns, [r["params"] for r in rows], [r["effects"] for r in rows])
        phi = _basis(u, g)
        # a feature the design's simulations did not measure (a conditioned bulk density in a design
        # made before backends measured it, a compressibility without a ramp) is not predicted
        features = tuple(n for n in FEATURES if any(math.isfinite(r["features"].get(n, math.nan)) for r in rows))
        y = np.array([[r["features"].get(n, math.nan) for n in features] for r in rows], dtype=float)
        coef = np.zeros((phi.shape[1], len(features)))
        for j in range(len(features)):
            ok = np.isfinite(y[:, j])
            coef[:, j] = np.linalg.lstsq(phi[ok], y[ok, j], rcond=None)[0]
        full = np.all(np.isfinite(y), axis=1)
        resid = y[full] - phi[full] @ coef
        dof = max(int(full.sum()) - np.linalg.matrix_rank(phi[full]), 1)
        cov = resid.T @ resid / dof
        plain = ~np.any(g[full] != 0.0, axis=1)
        plain_cov = (resid[plain].T @ resid[plain] / plain.sum() * full.sum() / dof
                     if plain.sum() >= PLAIN_ROWS_MIN else None)
        return cls(model, columns, params, coef, cov, len(rows), plain_cov, features,
                   mismatch_offsets(rows, mismatched, features))

    @staticmethod
    def _inputs(model, params, columns, natural: list[dict[str, float]], effects: list[dict[str, float]]):
        box = model.box()
        u = box.scaled(np.array([[p[n] for n in box.space.names] for p in natural]))
        g = np.array([[float(params[c].scaled(e[c])) if c in e else 0.0 for c in columns] for e in effects], dtype=float)
        return u, g.reshape(len(effects), len(columns))

    def mean(self, params: dict[str, float], effects: dict[str, float], mismatch: str = "") -> np.ndarray:
        """The features' mean at a point, shape (F,), made with the procedure mismatch ``mismatch``
        (:data:`~calibrax.diagnosis.benchmark.cases.MISMATCHES`; ``""``: the model's procedure)."""
        u, g = self._inputs(self.model, self.params, self.columns, [params], [effects])
        out = (_basis(u, g) @ self.coef)[0]
        if mismatch:
            if mismatch not in self.mismatch:
                raise ConfigError("--design", f"the design has no block of the mismatch {mismatch!r}; remake it "
                                  "(python benchmarks/diagnosis.py make-mismatch)")
            out = out + self.mismatch[mismatch]
        return out

    def draw(self, params: dict[str, float], effects: dict[str, float], n: int,
             rng: np.random.Generator, mismatch: str = "") -> list[dict[str, float]]:
        """``n`` simulated tests' features at a point (made with the procedure ``mismatch``)."""
        values = rng.multivariate_normal(self.mean(params, effects, mismatch), self.cov, size=n, method="eigh")
        return [dict(zip(self.features, map(float, v))) for v in values]

def mismatch_offsets(rows: list[dict[str, Any]], mismatched: list[dict[str, Any]],
                     features: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Each procedure mismatch's offset of the features' means, shape (F,): the mean difference of
    its rows from the design's rows of the same point and seed (the same poured bed, so the pairs
    share part of their seed noise; another engine's beds are its own). A constant offset over the
    box: the blocks run the calibrated point and a few baseline points only, too few for a slope.
    A feature the mismatch's rows do not measure (LIGGGHTS has no compressibility ramp) keeps the
    design's value: offset 0."""
    by_key = {(r["point"], int(r["seed"])): r for r in rows}
    out: dict[str, np.ndarray] = {}
    for kind in sorted({r["mismatch"] for r in mismatched}):
        diffs = [[m["features"].get(n, math.nan) - by_key[m["point"], int(m["seed"])]["features"].get(n, math.nan)
                  for n in features] for m in mismatched
                 if m["mismatch"] == kind and (m["point"], int(m["seed"])) in by_key]
        if diffs:
            d = np.array(diffs, dtype=float)
            seen = np.isfinite(d)
            # a feature the mismatched engine does not measure keeps the model's (offset 0)
            out[kind] = np.where(seen, d, 0.0).sum(axis=0) / np.maximum(seen.sum(axis=0), 1)
    return out


def load_design(path: Path | None = None) -> dict[str, Any]:
    path = Path(path) if path is not None else DEFAULT_DESIGN
    try:
        data = json.loads(path.read_text())
        data["rows"][0]["features"]
    except (OSError, ValueError, KeyError, IndexError, TypeError) as exc:
        raise ConfigError("--design", f"{path}: not a design file written by export_design ({exc})") from None
    return data


def measurement_noise(features: dict[str, float], noise: MeasurementNoise, rng: np.random.Generator) -> dict[str, float]:
    """Relative measurement noise per feature: τ/σ ratios carry τ's and σ's, curve shapes τ's,
    the densities their own, the compressibility its own."""
    ratio = math.hypot(noise.tau, noise.sigma)
    own = {"bulk_density": noise.density, "conditioned_bulk_density": noise.density,
           "compressibility": noise.compressibility, "initial_slope": noise.tau, "peak_prominence": noise.tau}
    out = {}
    for n, v in features.items():
        sd = own.get(n, ratio)
        out[n] = v * (1.0 + sd * rng.standard_normal())
    return out


#: independent draws a mismatch's detection rate is measured on, and the rates above and below
#: which its right answer is "none of the candidates" and "none" (between: either is right, and
#: only a listed effect named counts, as a false alarm)
POWER_DRAWS = 16
BEYOND_POWER, INSIDE_POWER = 0.8, 0.2
EITHER = f"{NO_EFFECT} or {NONE_OF_THEM}"


def mismatch_power(truth: TruthEmulator, kind: str, params: dict[str, float], seed: int,
                   draws: int = POWER_DRAWS, fit_on: tuple[str, ...] = gaps.DEFAULT_FIT) -> float:
    """How often the verdict's baseline test (:func:`calibrax.diagnosis.verdict.baseline_test`)
    finds the mismatch ``kind`` at ``params`` beyond the noise: the share of ``draws`` cases
    (replicates, measurement noise and a design drawn afresh, independent of the benchmark's cases)
    whose model without any effect misfits. Measured with the diagnosis's own noise model, so
    that "beyond the noise" means what the verdict can see."""
    from calibrax.diagnosis.run import candidate_spaces, score_design
    from calibrax.diagnosis.verdict import baseline_test

    model = truth.model
    effects, points, box = model.effects(), model.design(), model.box()
    effect_params = {p.name: p for e in effects for p in e.parameters}
    label = CaseLabel("power", CLASS_MISMATCH, "", kind, "emulator", params, {}, kind)
    hits = 0
    for i in range(draws):
        rng = np.random.default_rng([seed, 48, i])
        experiment = make_case(truth, label, MeasurementNoise(), 3, rng)
        design = [truth.draw(p.params, p.effect_values, len(p.seeds), rng) for p in points]
        with _quiet():
            scored = score_design(experiment, candidate_spaces(effects, None), points, design, 0, box, effect_params,
                                  model.seed)
        hits += baseline_test(scored.design, scored.target, fit_on, model.seed).misfits
    return hits / draws


def plan_emulated(model: BenchmarkModel, per_class: int, seed: int,
                  truth: TruthEmulator | None = None) -> list[CaseLabel]:
    """``per_class`` cases of every magnitude of every listed effect, ``per_class`` × 3 of no
    effect, and ``per_class`` × 2 of an unlisted effect alone and of a listed and an unlisted one
    together (:func:`~calibrax.diagnosis.benchmark.cases.listed_and_unlisted`, in turn), all at the
    model's answer: the campaign's answer is then the truth's calibrated parameters, so the gap
    "before" is the hidden effect's alone and the oracle (those parameters with the effect) is the
    truth itself. Cases made elsewhere than at the answer carry a parameter mismatch in their gap
    that a campaign calibrated on them would not leave; the DEM level's cases do (see there).

    With a ``truth`` whose design has mismatch blocks, per procedure mismatch ``per_class`` cases
    of the mismatch alone (expected "none of the candidates" where :func:`mismatch_power` finds it
    beyond the noise in at least ``BEYOND_POWER`` of independent draws, "none" where in at most
    ``INSIDE_POWER``, either in between) and ``per_class`` of the mismatch with
    a listed effect at its large magnitude on top (each listed effect in turn; expected: its name)."""
    from calibrax.diagnosis.benchmark.plan import listed_classes

    rows = []   # class, level, params, effects, expected answer, mismatch

    def params() -> dict[str, float]:
        return dict(model.centre)

    listed = listed_classes(model)
    for name, pname in listed:
        for level, value in MAGNITUDES[pname].items():
            rows += [(name, level, params(), {pname: value}, name, "") for _ in range(per_class)]
    rows += [(CLASS_NONE, "", params(), {}, NO_EFFECT, "") for _ in range(3 * per_class)]
    rows += [(CLASS_UNLISTED, "rolling friction", params(), {"rolling_friction": ROLLING_FRICTION_TRUTH},
              expected_answer(CLASS_UNLISTED), "") for _ in range(2 * per_class)]
    mixed = listed_and_unlisted(listed)
    if mixed:
        pairs = (mixed[k % len(mixed)] for k in range(2 * per_class))
        rows += [(CLASS_MIXED, f"{name} + rolling friction", params(), dict(effects), name, "")
                 for name, effects in pairs]
    for kind in sorted(truth.mismatch) if truth is not None else ():
        power = mismatch_power(truth, kind, params(), seed)
        expected = NONE_OF_THEM if power >= BEYOND_POWER else NO_EFFECT if power <= INSIDE_POWER else EITHER
        rows += [(CLASS_MISMATCH, f"{kind} (detected in {power:.0%})", params(), {}, expected, kind)
                 for _ in range(per_class)]
        on_top = [(name, {pname: MAGNITUDES[pname]["large"]}) for name, pname in listed if pname in MAGNITUDES]
        rows += [(CLASS_MISMATCH_LISTED, f"{kind} + {name}", params(), dict(effects), name, kind)
                 for name, effects in (on_top[k % len(on_top)] for k in range(per_class if on_top else 0))]
    ids = opaque_ids(len(rows), seed)
    return sorted((CaseLabel(i, k, expected, lvl, "emulator", p, eff, mismatch)
                   for i, (k, lvl, p, eff, expected, mismatch) in zip(ids, rows)), key=lambda c: c.case)


def make_case(truth: TruthEmulator, label: CaseLabel, noise: MeasurementNoise, replicates: int,
              rng: np.random.Generator) -> list[dict[str, float]]:
    """The replicates' features of a case."""
    return [measurement_noise(f, noise, rng)
            for f in truth.draw(label.params, label.effects, replicates, rng, label.mismatch)]


def diagnose_emulated(truth: TruthEmulator, case: str, experiment: list[dict[str, float]], rng: np.random.Generator,
                      oracle: CaseLabel | None = None, fit_on: tuple[str, ...] = gaps.DEFAULT_FIT) -> Answer:
    """Diagnose one case's replicate features with the truth emulator standing in for the simulator."""
    from calibrax.diagnosis.run import candidate_spaces, judged_verdict, score_design

    model = truth.model
    effects = model.effects()
    points = model.design()
    box = model.box()
    effect_params = {p.name: p for e in effects for p in e.parameters}
    design = [truth.draw(p.params, p.effect_values, len(p.seeds), rng) for p in points]
    scored = score_design(experiment, candidate_spaces(effects, None), points, design, 0, box, effect_params, model.seed)
    names = scored.design.names
    judge = tuple(n for n in names if gaps.group_of(n) not in fit_on)
    before = gaps.gap_size([g for g in scored.before if g.name in judge])

    def simulate(point, effect) -> list[dict[str, float]]:
        return truth.draw(point.params, point.effect_values, model.budget.confirm, rng)

    with _quiet():   # one log line per case and design is the progress's job here
        final = judged_verdict(scored, box, {e.name: e for e in effects}, fit_on, model.budget, model.seed, simulate)
    adopted = final.adopted
    after = adopted.gap_after if adopted else before
    oracle_after = math.nan
    if oracle is not None and oracle.effects and oracle.klass not in OTHER_CLASSES:
        sims = truth.draw(oracle.params, oracle.effects, model.budget.confirm, rng)
        oracle_after = gaps.gap_size([g for g in gaps.feature_gaps(sims, experiment, names, scored.seed_sd)
                                      if g.name in judge])
    models = scored.ranking.models
    return Answer(case, final.name, tuple(m.name for m in models), {m.name: m.probability for m in models},
                  {m.name: dict(m.effect_mean) for m in models if m.effect_mean}, before, after, oracle_after,
                  unexplained=final.unexplained, held_out=len(judge), best_candidate=final.best_candidate,
                  tried=tuple(f"{c.effect}: {c.outcome}" for c in final.confirmations))


@contextmanager
def _quiet():
    logger = logging.getLogger("calibrax")
    level = logger.level
    logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(level)


def run_emulated(truth: TruthEmulator, labels: list[CaseLabel], seed: int, noise: MeasurementNoise = MeasurementNoise(),
                 replicates: int = 3, progress=None) -> list[Answer]:
    """Make and diagnose every labelled case; the diagnosis sees only the replicates' features."""
    answers = []
    for i, label in enumerate(labels):
        rng = np.random.default_rng([seed, 3, i])
        experiment = make_case(truth, label, noise, replicates, rng)
        answers.append(diagnose_emulated(truth, label.case, experiment, rng, oracle=label))
        if progress:
            progress(i + 1, len(labels))
    return answers


def export_design(model: BenchmarkModel, outcomes: list, points: list, about: str, mismatch: str = "") -> dict[str, Any]:
    """The shipped design's data: every finished simulation's point, effects, seed and features
    (and the procedure mismatch it was made with, for a mismatch block's rows)."""
    from calibrax.core.data.features import result_features

    peak_window = model.spec.procedure.peak_window
    rows = []
    for pt, out in zip(points, outcomes):
        for result in out.good:
            rows.append({"point": pt.label, "params": dict(pt.params), "effects": dict(pt.effect_values),
                         "seed": int(result.provenance.seed), **({"mismatch": mismatch} if mismatch else {}),
                         "features": gaps.diagnosis_features(result_features(result, peak_window))})
    return {"about": about, "model": model.source.name, "rows": rows}
