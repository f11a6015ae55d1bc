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
   (:func:`judge_confirmation`): it is confirmed where the held-out gap after is inside the noise
   and no worse than the noise of the comparison allows, or, where a gap is left, shrunk beyond
   that noise; it is refuted where it made the held-out gap worse beyond that noise, or left it
   beyond the noise without shrinking it.
3. Where the baseline misfits and no candidate is confirmed, the answer is "none of the
   candidates", with the best candidate and why it failed.

**The comparison's noise.** "Before" is the calibrated point's seeds against the experiment,
"after" the recalibration's fresh seeds against the same experiment. Under "the recalibration
changes nothing on the held-out features", the after means scatter about the before means with
the seed s.d. times √(1/n_before + 1/n_after), correlated as the design's residuals are; the
held-out gap (RMS z) that this gives, drawn ``NULL_DRAWS`` times, has a 5 % and a 95 % quantile:
below the first the gap shrank beyond noise, above the second it grew beyond noise.
"""

from __future__ import annotations

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

CONFIRMED, WORSE, NOT_SHRUNK = "confirmed", "worse", "not shrunk"


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
    names = tuple(design.names[j] for j in keep)
    sub = Design(design.unit, design.effects, design.effect_columns, design.features[:, keep], names)
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
    recalibrated: dict[str, Any] = field(default_factory=dict)
    after: tuple[gaps.FeatureGap, ...] = ()

    @property
    def confirmed(self) -> bool:
        return self.outcome == CONFIRMED

    @property
    def gap_left(self) -> bool:
        """A confirmed candidate that leaves the held-out gap beyond the noise."""
        return self.confirmed and self.gap_after > self.limit

    def words(self) -> str:
        change = (f"the held-out gap went from {self.gap_before:.2f} to {self.gap_after:.2f} (RMS z; seed noise alone "
                  f"stays below {self.limit:.2f}, and a recalibration that changed nothing would give "
                  f"{self.null_low:.2f} to {self.null_high:.2f})")
        if self.outcome == WORSE:
            return f"recalibrated with {self.label}, {change}: worse beyond the noise, so its own confirmation refutes it"
        if self.outcome == NOT_SHRUNK:
            return f"recalibrated with {self.label}, {change}: still beyond the noise and not shrunk beyond it"
        if self.gap_left:
            return f"recalibrated with {self.label}, {change}: shrunk beyond the noise, though not into it"
        if self.gap_before > self.limit:
            return f"recalibrated with {self.label}, {change}: brought into the noise"
        return f"recalibrated with {self.label}, {change}: kept inside the noise"

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "label": self.label, "outcome": self.outcome, "gap_before": self.gap_before,
                "gap_after": self.gap_after, "limit": self.limit, "null_interval": [self.null_low, self.null_high],
                "words": self.words(), "recalibrated": self.recalibrated}


def null_interval(before: list[gaps.FeatureGap], corr: np.ndarray, n_after: int,
                  seed: int = 0) -> tuple[float, float]:
    """The :data:`NULL_QUANTILES` of the held-out gap after a recalibration that changed nothing.

    Args:
        before: the held-out features' gaps at the calibrated point.
        corr: their residual correlation, shape (k, k), in the order of ``before``.
        n_after: the confirmation's seeds.
    """
    if not before or n_after < 1:
        return math.nan, math.nan
    sim_mean = np.array([g.sim_mean for g in before])
    sd = np.array([g.sim_sd for g in before])
    spread = sd * math.sqrt(1.0 / max(g.n_sim for g in before) + 1.0 / n_after)
    cov = spread[:, None] * corr * spread[None, :]
    draws = np.random.default_rng([seed, 48]).multivariate_normal(sim_mean, cov, size=NULL_DRAWS, method="eigh")
    after = [gaps.FeatureGap(g.name, g.group, g.experiment_mean, g.experiment_sd, g.n_experiment, 0.0, g.sim_sd,
                             n_after) for g in before]
    se = np.array([g.stderr for g in after])
    e_mean = np.array([g.experiment_mean for g in before])
    rms = np.sqrt(np.mean(((draws - e_mean) / se) ** 2, axis=1))
    low, high = np.quantile(rms, NULL_QUANTILES)
    return float(low), float(high)


def judge_confirmation(effect: str, label: str, before: list[gaps.FeatureGap], after: list[gaps.FeatureGap],
                       judge: tuple[str, ...], corr: np.ndarray, n_after: int, recalibrated: dict[str, Any],
                       seed: int = 0) -> Confirmation:
    """Judge one candidate's confirmation on the held-out features ``judge`` (see the module docstring).

    Args:
        before, after: every feature's gap at the calibrated point and at the recalibration.
        judge: the held-out features.
        corr: the residual correlation of ``judge``, shape (k, k).
        n_after: the confirmation's seeds.
    """
    held_before = [g for n in judge for g in before if g.name == n]
    held_after = [g for g in after if g.name in judge]
    limit = gaps.noise_gap_limit(len(held_before))
    b, a = gaps.gap_size(held_before), gaps.gap_size(held_after)
    low, high = null_interval(held_before, corr, n_after, seed)
    if not math.isfinite(a) or a > high:
        outcome = WORSE
    elif a <= limit or a < low:
        outcome = CONFIRMED
    else:
        outcome = NOT_SHRUNK
    return Confirmation(effect, label, outcome, b, a, limit, low, high, recalibrated, tuple(after))


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
        return next((c for c in self.confirmations if c.confirmed and c.effect == self.name), None)

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
           unconfirmed: str = "no feature is held out to confirm it on") -> Verdict:
    """The verdict (see the module docstring) from the design's ranking, the baseline on the fit
    features and ``confirm``, which recalibrates, simulates and judges one candidate by name.
    ``confirm`` None: nothing can be confirmed (``unconfirmed`` says why), so the design's ranking
    stands, said to be unconfirmed."""
    best = next((m for m in ranking.models if m.name != NO_EFFECT), None)
    best_name = best.name if best else ""
    if baseline is None or confirm is None:
        return Verdict(ranking.verdict, f"{ranking.reason} (unconfirmed: {unconfirmed})", baseline,
                       (), ranking.unexplained, best_name)
    if ranking.verdict == NONE_OF_THEM:
        return Verdict(NONE_OF_THEM, f"none of the candidates: {ranking.reason}", baseline, (), (), best_name)
    if not baseline.misfits:
        proposed = (f"; the design's fit preferred {best.label} (p = {best.probability:.2f}), which would only "
                    "explain noise" if ranking.verdict not in (NO_EFFECT, NONE_OF_THEM) and best else "")
        return Verdict(NO_EFFECT, f"no effect: {baseline.words()}{proposed}", baseline, (), (), best_name)
    tried = candidates_to_confirm(ranking)
    if not tried:
        return Verdict(NONE_OF_THEM, f"none of the candidates: {baseline.words()}, and no candidate's Bayes factor "
                       f"against no effect reaches {MIN_BAYES_FACTOR:g} ({ranking.reason})", baseline, (), (), best_name)
    done: list[Confirmation] = []
    for model in tried:
        result = confirm(model.name)
        done.append(result)
        if result.confirmed:
            left = tuple(ranking.unexplained if model.name == ranking.verdict else ())
            if result.gap_left:
                left += (f"the held-out features (RMS z {result.gap_after:.2f} after, beyond the noise's "
                         f"{result.limit:.2f})",)
            words = (f"{model.label} explains the gap (p = {model.probability:.2f}, confirmed): {baseline.words()}; "
                     f"{result.words()}"
                     + (f"; it leaves {', '.join(left)}: an effect outside the candidates acts beside it" if left else ""))
            if len(done) > 1:
                words += "; before it, " + "; ".join(c.words() for c in done[:-1])
            return Verdict(model.name, words, baseline, tuple(done), left, best_name)
    return Verdict(NONE_OF_THEM, f"none of the candidates: {baseline.words()}, and no candidate fixes it: "
                   + "; ".join(c.words() for c in done), baseline, tuple(done), (), best_name)
