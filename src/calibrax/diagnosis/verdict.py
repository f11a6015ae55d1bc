"""The verdict a diagnosis gives: a candidate is named only where its own confirmation bears it out.

The design's ranking (:mod:`calibrax.diagnosis.scoring`) proposes; the verdict disposes:

1. **Is there a gap to explain?** The model without any effect, its calibrated parameters refitted,
   is tested against the noise (:func:`baseline_fit`): its best fit's joint misfit rᵀΣ⁻¹r against
   χ² on (features − calibrated parameters) degrees of freedom at ``BASELINE_ADEQUACY``, and no
   feature beyond |z| = 3; once on the features a recalibration is fitted on (the ``fit_on``
   groups), once on every feature of the design (:func:`baseline_test`). Where both fit within
   the noise, the answer is "none" whatever the posterior says: a candidate that improves on a fit
   that was already good explains noise. (Issue 48 asked for the fit features alone; but where a
   campaign was calibrated on the locus and the diagnosis fits on the locus too, the locus fits by
   construction and the gap shows only in the held-out density: refusing it there would answer
   "none" to a density 6 standard errors off. The confirmation still judges on the held-out
   features alone, with fresh seeds, so the held-out gap is never both the evidence and the judge
   of one recalibration.)
2. **Does the candidate earn its name?** The top candidate (then the runner-up, up to
   ``MAX_TRIED``, each with a Bayes factor of at least 3 against no effect) is recalibrated on the
   fit features and simulated with fresh seeds; the held-out features judge it
   (:func:`judge_confirmation`): it is confirmed where the held-out gap after is inside the seed
   noise's limit (brought into it, or kept inside it where it started there), or, where a gap is
   left beyond it, where the gap shrank beyond the noise of the comparison: below its 5 %
   quantile, or with a move of the held-out features toward the experiment beyond ``TOWARD_Z``,
   or with a move along the one the design emulator predicts for the recalibration beyond
   ``TOWARD_Z`` where that prediction is toward the experiment (each a one-sided 5 % test; where
   nothing changed, together about 10–15 %); it is refuted where the
   gap after is beyond the limit and grew beyond the comparison's noise (worse), or stayed beyond
   it without moving toward the experiment where the design emulator predicted that the
   recalibration moves the held-out features beyond that noise (``VISIBLE_Z``; not shrunk).
   Where it predicted no such move, the held-out features cannot see the candidate and its
   confirmation can neither bear it out nor refute it (unseen): where the fit features show a gap
   (its evidence lies there), the candidate is named on the design's evidence, said to be
   unconfirmed, and the held-out gap it leaves flagged as an
   effect outside the candidates (a size distribution shows in the densities, which the
   recalibration is fitted on, and barely in the flow and the shape it is judged on; where an
   unlisted effect makes the held-out gap, refusing the size distribution would refuse the
   listed effect beside it that issue 48 asks to be named).
3. Where the baseline misfits and no candidate is confirmed, the answer is "none of the
   candidates", with the best candidate and why it failed.
4. **Across fidelities "no effect" is confirmed too.** The baseline's refit is read through an
   emulator whose response to the calibrated parameters comes from the cheap level, so where the
   target's replicates show a gap (beyond the seed noise's limit), the refit is simulated at the
   target with fresh seeds and judged as a candidate's recalibration is. Refuted there, the
   baseline does not fit after all, and the candidates are tried as in 2. (Measured at
   `converged` with a hidden wall friction: the design's emulator refitted μs and called the gap
   noise, docs/explanation/diagnosis.md, "Across fidelities".)

**The comparison's noise.** "Before" is the calibrated point's seeds against the experiment,
"after" the recalibration's fresh seeds against the same experiment. Under "the recalibration
changes nothing on the held-out features", the after means scatter about the before means with
the seed s.d. times √(1/n_before + 1/n_after), correlated as the design's residuals are; the
held-out gap (RMS z) that this gives, drawn ``NULL_DRAWS`` times, has a 5 % and a 95 % quantile:
above the second the gap grew beyond noise. Whether it shrank is read feature by feature: the
sum of |z| before − |z| after over the held-out features, standardised by its mean and s.d.
under the same null (``toward``; :func:`toward_experiment`). The RMS gap alone is a weak test
where an effect outside the candidates leaves a large gap on some held-out features: their z²
dominate it and their noise with them, and a listed effect that removes its own part of the gap
(a cohesion's compressibility beside a shape effect's flow) would be refuted for what it never
claimed to explain.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from calibrax.diagnosis import gap as gaps
from calibrax.diagnosis.scoring import (IMPLAUSIBLE_Z, MIN_BAYES_FACTOR, NO_EFFECT, NONE_OF_THEM, Design,
                                        Emulator, ModelScore, Ranking, Target, score_model)

#: the baseline's χ² test on the fit features: its misfit is beyond the noise below this p-value
#: (the ranking's own adequacy cut-off: a stricter one would call a noisy control a gap)
BASELINE_ADEQUACY = 0.01
#: candidates confirmed in turn at most (each costs the budget's ``confirm`` simulations)
MAX_TRIED = 2
#: draws of the comparison's null distribution, and its quantiles
NULL_DRAWS = 4000
NULL_QUANTILES = (0.05, 0.95)
#: a move toward the experiment beyond this many of its s.d. under the null is beyond the noise
#: (one-sided 5 %)
TOWARD_Z = 1.645

#: the design emulator's predicted move of the held-out features, in s.d. of the comparison's
#: noise (Mahalanobis), below which a confirmation cannot see the candidate
VISIBLE_Z = 2.0

CONFIRMED, WORSE, NOT_SHRUNK, UNSEEN = "confirmed", "worse", "not shrunk", "unseen"
#: a refit of the model without an effect that, by the design emulator's own prediction, cannot
#: close the gap the target measured: refuted without a simulation
OUT_OF_REACH = "out of reach"
#: unseen by the held-out features where the fit features show no gap: it explains nothing there is
UNSEEN_NO_GAP = "unseen, no gap on the fit features"


@dataclass(frozen=True)
class BaselineFit:
    """The model without any effect refitted on the fit features.

    Attributes:
        features: the fit features' names.
        chi2, dof: its best fit's joint misfit and degrees of freedom.
        z: each fit feature's standardised residual at that fit, shape (F_fit,).
    """

    features: tuple[str, ...]
    chi2: float
    dof: int
    z: np.ndarray

    @property
    def p_value(self) -> float:
        from scipy.stats import chi2

        return float(chi2.sf(self.chi2, max(self.dof, 1))) if math.isfinite(self.chi2) else math.nan

    @property
    def beyond(self) -> tuple[str, ...]:
        """The fit features beyond |z| = 3."""
        return tuple(n for n, z in zip(self.features, self.z) if abs(z) > IMPLAUSIBLE_Z)

    @property
    def misfits(self) -> bool:
        """Whether the baseline misfits the fit features beyond the noise."""
        return bool(self.beyond) or self.p_value < BASELINE_ADEQUACY

    @property
    def fit_misfits(self) -> bool:
        """The same (one test, on the fit features)."""
        return self.misfits

    def detail(self) -> str:
        return (f"{', '.join(self.beyond)} beyond |z| = {IMPLAUSIBLE_Z:g}" if self.beyond
                else f"χ² {self.chi2:.1f} on {self.dof} degrees of freedom, p = {self.p_value:.2g}")

    def words(self) -> str:
        return (f"the model without any effect, refitted, {'misfits' if self.misfits else 'fits'} the fit features "
                f"({', '.join(self.features)}) {'beyond' if self.misfits else 'within'} the noise ({self.detail()})")

    def to_dict(self) -> dict[str, Any]:
        return {"features": list(self.features), "chi2": self.chi2, "dof": self.dof, "p": self.p_value,
                "misfits": self.misfits, "beyond": list(self.beyond)}


@dataclass(frozen=True)
class BaselineTest:
    """The model without any effect refitted twice (see the module docstring): on the fit features
    and on every feature; it misfits where either does."""

    fit: BaselineFit
    every: BaselineFit

    @property
    def misfits(self) -> bool:
        return self.fit.misfits or self.every.misfits

    @property
    def fit_misfits(self) -> bool:
        """Whether the fit features alone show a gap (where an unseen candidate's evidence lies)."""
        return self.fit.misfits

    def words(self) -> str:
        if self.fit.misfits or self.every.features == self.fit.features:
            return self.fit.words()
        how = "but misfits every feature together beyond it" if self.every.misfits else "and every feature too"
        return f"{self.fit.words()}, {how} ({self.every.detail()})"

    def to_dict(self) -> dict[str, Any]:
        return {"misfits": self.misfits, "fit_features": self.fit.to_dict(), "every_feature": self.every.to_dict()}


def baseline_fit(design: Design, target: Target, groups: tuple[str, ...] | None, seed: int = 0) -> BaselineFit:
    """Refit the model without any effect on the ``groups``' features (None: every feature)."""
    keep = [j for j, n in enumerate(design.names) if groups is None or gaps.group_of(n) in groups]
    sub = design.only(keep)
    names = sub.names
    fit = score_model(Target(target.mean[keep], target.sd[keep], target.n), Emulator.fit(sub), None, seed)
    return BaselineFit(names, fit.chi2, fit.dof, np.asarray(fit.z))


@dataclass(frozen=True)
class Confirmation:
    """What one candidate's confirmation showed on the held-out features.

    Attributes:
        effect, label: the candidate.
        outcome: ``confirmed``, ``worse`` (the held-out gap grew beyond the comparison's noise) or
            ``not shrunk`` (it stayed beyond the noise without shrinking beyond it).
        gap_before, gap_after: the held-out RMS z at the calibrated point and at the recalibration.
        limit: the RMS z over the held-out features that seed noise alone stays below in 95 % of
            tests (:func:`~calibrax.diagnosis.gap.noise_gap_limit`).
        null_low, null_high: the 5 % and 95 % quantiles of the gap after if the recalibration
            changed nothing (see the module docstring).
        toward: the held-out features' move toward the experiment, in its s.d. under that null.
        as_predicted: their move along the design emulator's predicted one, in its s.d. under that
            null (NaN where nothing was predicted or the prediction leads away from the experiment).
        visible: the design emulator's predicted move of the held-out features from the
            calibrated point to the recalibration, in s.d. of the comparison's noise (NaN: not
            predicted, read as visible).
        recalibrated: the recalibration's record (:func:`calibrax.diagnosis.run.recalibration`).
        after: the held-out and fit features' gaps at the recalibration.
    """

    effect: str
    label: str
    outcome: str
    gap_before: float
    gap_after: float
    limit: float
    null_low: float
    null_high: float
    toward: float = math.nan
    visible: float = math.nan
    as_predicted: float = math.nan
    recalibrated: dict[str, Any] = field(default_factory=dict)
    after: tuple[gaps.FeatureGap, ...] = ()

    @property
    def confirmed(self) -> bool:
        return self.outcome == CONFIRMED

    @property
    def stands(self) -> bool:
        """Confirmed, or unseen by the held-out features (not refuted)."""
        return self.outcome in (CONFIRMED, UNSEEN)

    @property
    def gap_left(self) -> bool:
        """A candidate that stands and leaves the held-out gap beyond the noise."""
        return self.stands and self.gap_after > self.limit

    def words(self) -> str:
        change = (f"the held-out gap went from {self.gap_before:.2f} to {self.gap_after:.2f} (RMS z; seed noise alone "
                  f"stays below {self.limit:.2f}, and a recalibration that changed nothing would give "
                  f"{self.null_low:.2f} to {self.null_high:.2f})")
        move = f"a move toward the experiment of {self.toward:.1f} s.d. of the comparison's noise" + (
            f" ({self.as_predicted:.1f} along the design's prediction)" if math.isfinite(self.as_predicted) else "")
        if self.outcome == OUT_OF_REACH:
            return (f"recalibrated with {self.label}, the design's emulator moves the features so little from the "
                    f"target's calibrated point that, from what the target measured there, the gap over every "
                    f"feature stays at RMS z {self.gap_after:.2f} ({self.gap_before:.2f} before; seed noise alone "
                    f"stays below {self.limit:.2f}): the refit cannot reach the experiment at the target, so it is "
                    "refuted without a simulation")
        if self.outcome == WORSE:
            return f"recalibrated with {self.label}, {change}: worse beyond the noise, so its own confirmation refutes it"
        if self.outcome == UNSEEN_NO_GAP:
            return (f"recalibrated with {self.label}, {change}: the held-out features cannot see it (a predicted move "
                    f"of {self.visible:.1f} s.d. of the comparison's noise), and the fit features, where its evidence "
                    "lies, show no gap: it explains nothing that is there")
        if self.outcome == UNSEEN:
            return (f"recalibrated with {self.label}, {change}: still beyond the noise, but the design predicts a move "
                    f"of the held-out features of only {self.visible:.1f} s.d. of the comparison's noise (it would "
                    f"need {VISIBLE_Z:g}), so they cannot see it: unconfirmed, and not refuted")
        if self.outcome == NOT_SHRUNK:
            return (f"recalibrated with {self.label}, {change}: still beyond the noise and not below that range, "
                    f"{move} (it needs {TOWARD_Z:g}), so its own confirmation does not bear it out")
        if self.gap_left:
            return f"recalibrated with {self.label}, {change}: shrunk beyond the noise ({move}), though not into it"
        if self.gap_before > self.limit:
            return f"recalibrated with {self.label}, {change}: brought into the noise"
        return f"recalibrated with {self.label}, {change}: kept inside the noise"

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "label": self.label, "outcome": self.outcome, "gap_before": self.gap_before,
                "gap_after": self.gap_after, "limit": self.limit, "null_interval": [self.null_low, self.null_high],
                "toward": self.toward, "visible": self.visible, "as_predicted": self.as_predicted,
                "words": self.words(), "recalibrated": self.recalibrated}


def _null_spread(before: list[gaps.FeatureGap], n_after: int) -> np.ndarray:
    """The s.d. of each held-out feature's after mean about its before mean if the recalibration
    changed nothing, natural units, shape (k,)."""
    sd = np.array([g.sim_sd for g in before])
    return sd * math.sqrt(1.0 / max(g.n_sim for g in before) + 1.0 / n_after)


def _stderr_after(before: list[gaps.FeatureGap], n_after: int) -> np.ndarray:
    return np.array([gaps.FeatureGap(g.name, g.group, g.experiment_mean, g.experiment_sd, g.n_experiment, 0.0,
                                     g.sim_sd, n_after).stderr for g in before])


def _null_z(before: list[gaps.FeatureGap], corr: np.ndarray, n_after: int, seed: int) -> np.ndarray:
    """Draws of the held-out z after a recalibration that changed nothing, shape (NULL_DRAWS, k)."""
    spread = _null_spread(before, n_after)
    cov = spread[:, None] * corr * spread[None, :]
    sim_mean = np.array([g.sim_mean for g in before])
    draws = np.random.default_rng([seed, 48]).multivariate_normal(sim_mean, cov, size=NULL_DRAWS, method="eigh")
    return (draws - np.array([g.experiment_mean for g in before])) / _stderr_after(before, n_after)


def null_interval(null_z: np.ndarray) -> tuple[float, float]:
    """The :data:`NULL_QUANTILES` of the held-out gap after a recalibration that changed nothing,
    from :func:`_null_z`'s draws, shape (NULL_DRAWS, k)."""
    rms = np.sqrt(np.mean(null_z ** 2, axis=1))
    low, high = np.quantile(rms, NULL_QUANTILES)
    return float(low), float(high)


def toward_experiment(before: list[gaps.FeatureGap], after: list[gaps.FeatureGap], n_after: int,
                      null_z: np.ndarray) -> float:
    """How far the recalibration brought the held-out features toward the experiment: the sum over
    them of |z| before − |z| after (each in the after's standard errors), standardised by its mean
    and s.d. under :func:`_null_z`'s draws ``null_z`` (see the module docstring). A feature far off
    that no candidate explains adds its noise, not its square, so a candidate that brings its own
    features in is seen beside it. ``after`` in the order of ``before``."""
    se = _stderr_after(before, n_after)
    e_mean = np.array([g.experiment_mean for g in before])
    z_before = np.abs((np.array([g.sim_mean for g in before]) - e_mean) / se)
    z_after = np.abs((np.array([g.sim_mean for g in after]) - e_mean) / se)
    if not np.all(np.isfinite(z_after)):
        return math.nan
    null = np.sum(z_before - np.abs(null_z), axis=1)
    sd = float(np.std(null))
    return float((np.sum(z_before - z_after) - np.mean(null)) / sd) if sd > 0 else math.nan


def visibility(before: list[gaps.FeatureGap], predicted: np.ndarray, corr: np.ndarray, n_after: int) -> float:
    """The predicted move ``predicted`` of the held-out features (natural units, shape (k,), in
    the order of ``before``) in s.d. of the comparison's noise: √(Δᵀ C⁻¹ Δ), C the covariance of
    the after means about the before means if nothing changed."""
    spread = _null_spread(before, n_after)
    cov = spread[:, None] * corr * spread[None, :]
    d = np.asarray(predicted, dtype=float)
    return float(math.sqrt(max(d @ np.linalg.lstsq(cov, d, rcond=None)[0], 0.0)))


def along_prediction(before: list[gaps.FeatureGap], after: list[gaps.FeatureGap], predicted: np.ndarray,
                     corr: np.ndarray, n_after: int) -> float:
    """The held-out features' observed move projected on the design emulator's predicted move (both
    natural units, shape (k,), in the order of ``before``), in its s.d. if the recalibration
    changed nothing: Δ_obsᵀ C⁻¹ Δ_pred / √(Δ_predᵀ C⁻¹ Δ_pred). NaN where the prediction does not
    bring the held-out features toward the experiment (their summed |z| would not fall)."""
    spread = _null_spread(before, n_after)
    cov = spread[:, None] * corr * spread[None, :]
    pred = np.asarray(predicted, dtype=float)
    sim = np.array([g.sim_mean for g in before])
    e_mean = np.array([g.experiment_mean for g in before])
    se = _stderr_after(before, n_after)
    if not np.sum(np.abs(sim - e_mean) / se) > np.sum(np.abs(sim + pred - e_mean) / se):
        return math.nan
    w = np.linalg.lstsq(cov, pred, rcond=None)[0]
    norm = float(pred @ w)
    observed = np.array([g.sim_mean for g in after]) - sim
    return float(observed @ w / math.sqrt(norm)) if norm > 0 and np.all(np.isfinite(observed)) else math.nan


def judge_confirmation(effect: str, label: str, before: list[gaps.FeatureGap], after: list[gaps.FeatureGap],
                       judge: tuple[str, ...], corr: np.ndarray, n_after: int, recalibrated: dict[str, Any],
                       seed: int = 0, predicted: np.ndarray | None = None) -> Confirmation:
    """Judge one candidate's confirmation on the held-out features ``judge`` (see the module docstring).

    Args:
        before, after: every feature's gap at the calibrated point and at the recalibration.
        judge: the held-out features.
        corr: the residual correlation of ``judge``, shape (k, k).
        n_after: the confirmation's seeds.
        predicted: the design emulator's move of the ``judge`` features from the calibrated point
            to the recalibration, natural units, shape (k,) (None: not predicted, read as visible).
    """
    held_before = [g for n in judge for g in before if g.name == n]
    held_after = [g for n in judge for g in after if g.name == n]
    limit = gaps.noise_gap_limit(len(held_before))
    b, a = gaps.gap_size(held_before), gaps.gap_size(held_after)
    # one set of null draws serves both the RMS band and the move toward the experiment
    null_z = _null_z(held_before, corr, n_after, seed) if held_before and n_after >= 1 else None
    low, high = null_interval(null_z) if null_z is not None else (math.nan, math.nan)
    toward = (toward_experiment(held_before, held_after, n_after, null_z)
              if null_z is not None and len(held_after) == len(held_before) else math.nan)
    along = (along_prediction(held_before, held_after, predicted, corr, n_after)
             if predicted is not None and len(held_after) == len(held_before) else math.nan)
    if not math.isfinite(a):
        outcome = WORSE
    elif a <= limit:
        outcome = CONFIRMED
    elif a > high:
        outcome = WORSE
    elif a < b and (a < low or toward > TOWARD_Z or along > TOWARD_Z):
        outcome = CONFIRMED
    else:
        outcome = NOT_SHRUNK
    seen = visibility(held_before, predicted, corr, n_after) if predicted is not None else math.nan
    if outcome == NOT_SHRUNK and seen < VISIBLE_Z:
        outcome = UNSEEN
    return Confirmation(effect, label, outcome, b, a, limit, low, high, toward, seen, along, recalibrated, tuple(after))


@dataclass(frozen=True)
class Verdict:
    """The diagnosis's answer.

    Attributes:
        name: the confirmed effect's name, ``none`` or ``none of the candidates``.
        reason: the answer in words, with what the confirmation showed.
        baseline: the model without any effect refitted (:class:`BaselineTest`).
        confirmations: every candidate confirmed in turn (empty where none was tried).
        unexplained: what a confirmed candidate leaves (the design's features beyond |z| = 3 at its
            best fit, or the held-out gap left beyond the noise); empty otherwise.
        best_candidate: the most probable candidate (named or not).
    """

    name: str
    reason: str
    baseline: BaselineFit | BaselineTest | None
    confirmations: tuple[Confirmation, ...] = ()
    unexplained: tuple[str, ...] = ()
    best_candidate: str = ""

    @property
    def adopted(self) -> Confirmation | None:
        """The confirmation of the named effect (None where none was named)."""
        return next((c for c in self.confirmations if c.stands and c.effect == self.name), None)

    def to_dict(self) -> dict[str, Any]:
        return {"verdict": self.name, "reason": self.reason, "unexplained": list(self.unexplained),
                "best_candidate": self.best_candidate,
                "baseline": self.baseline.to_dict() if self.baseline else None,
                "confirmations": [c.to_dict() for c in self.confirmations]}


def baseline_test(design: Design, target: Target, fit_on: tuple[str, ...], seed: int = 0) -> BaselineTest:
    """The baseline refitted on the ``fit_on`` groups' features and on every feature."""
    return BaselineTest(baseline_fit(design, target, fit_on, seed), baseline_fit(design, target, None, seed))


def candidates_to_confirm(ranking: Ranking) -> list[ModelScore]:
    """The candidates worth confirming, most probable first: those whose Bayes factor against no
    effect reaches :data:`~calibrax.diagnosis.scoring.MIN_BAYES_FACTOR`, at most :data:`MAX_TRIED`."""
    none = ranking.model(NO_EFFECT)
    out = [m for m in ranking.models if m.name != NO_EFFECT
           and m.log_evidence - none.log_evidence >= math.log(MIN_BAYES_FACTOR)]
    return out[:MAX_TRIED]


def decide(ranking: Ranking, baseline: BaselineFit | BaselineTest | None, confirm: Callable[[str], Confirmation] | None,
           unconfirmed: str = "no feature is held out to confirm it on",
           refit: Confirmation | None = None) -> Verdict:
    """The verdict (see the module docstring) from the design's ranking, the baseline on the fit
    features and ``confirm``, which recalibrates, simulates and judges one candidate by name.
    ``confirm`` None: nothing can be confirmed (``unconfirmed`` says why), so the design's ranking
    stands, said to be unconfirmed.

    ``refit`` (across fidelities) is the confirmation at the target of the baseline's own refit,
    run where the baseline fit within the noise through the design's emulator and the target
    showed a gap (:func:`calibrax.diagnosis.run.refit_at_target`): where it stands, the answer is
    "no effect"; where the target refuted it, the baseline does not fit after all, and the
    candidates are tried as where it misfits."""
    best = next((m for m in ranking.models if m.name != NO_EFFECT), None)
    best_name = best.name if best else ""
    if baseline is None or confirm is None:
        return Verdict(ranking.verdict, f"{ranking.reason} (unconfirmed: {unconfirmed})", baseline,
                       (), ranking.unexplained, best_name)
    if ranking.verdict == NONE_OF_THEM and refit is None:
        return Verdict(NONE_OF_THEM, f"none of the candidates: {ranking.reason}", baseline, (), (), best_name)
    done: list[Confirmation] = []
    baseline_words = baseline.words()
    proposed = (f"; the design's fit preferred {best.label} (p = {best.probability:.2f}), which would only "
                "explain noise" if ranking.verdict not in (NO_EFFECT, NONE_OF_THEM) and best else "")
    if refit is not None and refit.stands:
        return Verdict(NO_EFFECT, f"no effect: the model without an effect, refitted, fits within the noise through "
                       f"the design's emulator{proposed}; at the target, {refit.words()}", baseline, (refit,), (),
                       best_name)
    if refit is not None:
        done.append(refit)
        baseline_words = ("the model without an effect, refitted, fit within the noise through the design's emulator, "
                          f"but at the target {refit.words()}, so it does not reach the experiment there; "
                          f"with that simulation in the design, {baseline_words}")
    elif not baseline.misfits:
        return Verdict(NO_EFFECT, f"no effect: {baseline_words}{proposed}", baseline, (), (), best_name)
    tried = candidates_to_confirm(ranking)
    if not tried:
        return Verdict(NONE_OF_THEM, f"none of the candidates: {baseline_words}, and no candidate's Bayes factor "
                       f"against no effect reaches {MIN_BAYES_FACTOR:g} ({ranking.reason})", baseline, tuple(done), (),
                       best_name)
    for model in tried:
        result = confirm(model.name)
        done.append(result)
        if result.outcome == UNSEEN and not baseline.fit_misfits:
            # its evidence lies in the fit features, and they show no gap: it explains nothing there is
            result = dataclasses.replace(result, outcome=UNSEEN_NO_GAP)
            done[-1] = result
        if result.stands:
            left = tuple(ranking.unexplained if model.name == ranking.verdict else ())
            if result.gap_left:
                left += (f"the held-out features (RMS z {result.gap_after:.2f} after, beyond the noise's "
                         f"{result.limit:.2f})",)
            how = "confirmed" if result.confirmed else "unconfirmed: the held-out features cannot see it"
            words = (f"{model.label} explains the gap (p = {model.probability:.2f}, {how}): {baseline_words}; "
                     f"{result.words()}"
                     + (f"; it leaves {', '.join(left)}: an effect outside the candidates acts beside it" if left else ""))
            before_it = [c for c in done[:-1] if c.effect != NO_EFFECT]
            if before_it:
                words += "; before it, " + "; ".join(c.words() for c in before_it)
            return Verdict(model.name, words, baseline, tuple(done), left, best_name)
    return Verdict(NONE_OF_THEM, f"none of the candidates: {baseline_words}, and no candidate fixes it: "
                   + "; ".join(c.words() for c in done if c.effect != NO_EFFECT), baseline, tuple(done), (), best_name)
