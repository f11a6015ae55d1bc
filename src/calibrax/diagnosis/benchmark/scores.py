"""Scoring a benchmark: each case's answer against its label, and the table and figure.

Scores (over the cases of the labels file that have an answer):

* **top-1**: the verdict is the hidden effect, over the listed-effect cases (per magnitude, and
  over medium and large together, the goal's set);
* **top-2**: the hidden effect is the verdict or one of the two most probable models;
* **confusion matrix**: rows are the classes, columns the verdicts;
* **false alarms**: the share of ``none`` cases whose verdict is not "none";
* **unlisted**: the share of unlisted-effect cases answered "none of the candidates";
* **listed + unlisted**: over the cases where a listed and an unlisted effect act together, the
  share whose verdict names the listed one, and the share that also flags the gap it leaves
  (:attr:`Answer.unexplained` not empty);
* **magnitude error**: |recovered − hidden| / hidden of the hidden effect's parameter, where
  "recovered" is the value the diagnosis tells the user (:attr:`Answer.recovered`: the
  recalibration's, else the design posterior's), over the cases whose verdict is right;
* **shrinkage against the oracle**: the diagnosis's held-out shrinkage over the oracle's (the
  true effect at its true magnitude, simulated with fresh seeds and compared on the same
  held-out features against the same "before"), over the cases where the held-out features show
  the effect: their gap before is beyond what seed noise alone gives (:func:`noise_gap_limit`) and
  the oracle shrinks it by at least :data:`MIN_ORACLE_SHRINKAGE` (elsewhere the ratio is one of
  two noises); a case the diagnosis recalibrated nothing for shrank by 0. A class with fewer than
  :data:`MIN_SHRINKAGE_CASES` such cases is reported, not judged: the held-out features do not
  see that effect (at ``tiny``, cohesion and a size distribution move the locus and the
  densities the recalibration is fitted to, and barely the flow and the τ curves' shape);
* **listed + unlisted** per listed effect as well (:attr:`Scores.mixed_by_effect`);
* **mismatch** (a procedure or an engine the design never saw, no effect), per kind and
  together: false alarms (a listed effect named), "none of the candidates" over the cases whose
  mismatch is beyond the noise (their ``expected``), "none" over those inside it, and the share
  of "none of the candidates" at the noise's edge, where either answer is right; and **mismatch +
  listed**: the listed effect named (:attr:`Scores.mismatch`).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from calibrax.diagnosis import gap as gaps
from calibrax.diagnosis.benchmark.cases import (CLASS_MISMATCH, CLASS_MISMATCH_LISTED, CLASS_MIXED, CLASS_NONE,
                                                CLASS_UNLISTED, MISMATCH_CLASSES, OTHER_CLASSES, CaseLabel)
from calibrax.diagnosis.scoring import NO_EFFECT, NONE_OF_THEM
from calibrax.errors import ConfigError

#: the goals of issues 20 and 34
GOAL_TOP1, GOAL_FALSE_ALARMS, GOAL_SHRINKAGE, GOAL_UNLISTED = 0.8, 0.1, 0.7, 0.5
#: the goals of issue 48 on the mismatch cases
GOAL_MISMATCH_FALSE_ALARMS, GOAL_MISMATCH_REJECTED = 0.1, 0.7
#: the oracle's held-out shrinkage a case needs for its ratio to count: where the true effect
#: itself explains less than a quarter of the held-out gap, that gap is noise and the ratio too
MIN_ORACLE_SHRINKAGE = 0.25
#: a case's ratio counts only where its held-out gap before (RMS z over k features) is beyond the
#: seed noise's 95 % quantile, √(χ²_k(q) / k) (:func:`noise_gap_limit`): 1.54 for the default
#: split's four held-out features. Measured at the emulator level: of the cohesion cases the former
#: rule counted (17 of 30), the held-out gap before was 0.5 to 1.8, the seed noise's own size, and
#: the ratio swung from 81 % to 39 % when the shipped design's rolling-friction block alone was remade
GAP_NOISE_QUANTILE = gaps.GAP_NOISE_QUANTILE
#: held-out features an answer without the count is read as having (the default split's)
DEFAULT_HELD_OUT = 4
#: a class needs this many counted cases for its median shrinkage ratio to be judged against the goal
MIN_SHRINKAGE_CASES = 5


@dataclass(frozen=True)
class Answer:
    """What the diagnosis said of one case.

    Attributes:
        case: the case id.
        verdict: an effect name, ``none`` or ``none of the candidates``.
        ranked: the models' names, most probable first.
        probabilities: {model name: probability}.
        effect_means: {model name: {parameter: posterior mean}} of every candidate's joint fit to
            the design (the ranking's posterior, on every feature).
        gap_before, gap_after: the held-out features' RMS z before and after the recalibration
            (after = before where nothing was recalibrated).
        oracle_after: the same for the oracle (NaN where no oracle was run).
        recovered: {parameter: value} of the named effect as the user is told it: the
            recalibration's value (fitted on the fit-on features; the log and diagnosis.json give
            it), or the verdict's design posterior where nothing was recalibrated. The magnitude
            error is scored on it.
        held_out: how many held-out features the gaps are over (0: not recorded, read as
            :data:`DEFAULT_HELD_OUT`).
        unexplained: what a named effect left beyond |z| = 3
            (:attr:`~calibrax.diagnosis.scoring.Ranking.unexplained`): the gap flagged as an
            effect outside the list's; empty where nothing was flagged.
        best_candidate: the most probable candidate of the design's ranking, named or not.
        tried: each candidate confirmed in turn and the outcome, ``"<effect>: <outcome>"``
            (:mod:`calibrax.diagnosis.verdict`).
    """

    case: str
    verdict: str
    ranked: tuple[str, ...]
    probabilities: dict[str, float]
    effect_means: dict[str, dict[str, float]]
    gap_before: float
    gap_after: float
    oracle_after: float = math.nan
    recovered: dict[str, float] = field(default_factory=dict)
    unexplained: tuple[str, ...] = ()
    held_out: int = 0
    best_candidate: str = ""
    tried: tuple[str, ...] = ()

    @property
    def magnitude(self) -> dict[str, float]:
        """What the magnitude error is scored on: :attr:`recovered`, or (answers written before it
        was kept) the verdict's design posterior."""
        return dict(self.recovered) or dict(self.effect_means.get(self.verdict, {}))

    @property
    def shrinkage(self) -> float:
        return _shrink(self.gap_before, self.gap_after)

    @property
    def oracle_shrinkage(self) -> float:
        return _shrink(self.gap_before, self.oracle_after)

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "ranked": list(self.ranked), "unexplained": list(self.unexplained),
                "tried": list(self.tried),
                "shrinkage": self.shrinkage,
                "oracle_shrinkage": self.oracle_shrinkage}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Answer":
        return cls(d["case"], d["verdict"], tuple(d["ranked"]), dict(d["probabilities"]),
                   {k: dict(v) for k, v in d.get("effect_means", {}).items()}, float(d["gap_before"]),
                   float(d["gap_after"]), float(d.get("oracle_after", math.nan)),
                   {k: float(v) for k, v in d.get("recovered", {}).items()}, tuple(d.get("unexplained", ())),
                   int(d.get("held_out", 0)), str(d.get("best_candidate", "")), tuple(d.get("tried", ())))


def noise_gap_limit(held_out: int) -> float:
    """:func:`calibrax.diagnosis.gap.noise_gap_limit` over ``held_out`` features (0: the default split's)."""
    return gaps.noise_gap_limit(held_out if held_out > 0 else DEFAULT_HELD_OUT)


def _shrink(before: float, after: float) -> float:
    return 1.0 - after / before if math.isfinite(before) and math.isfinite(after) and before > 0 else math.nan


def answer_from_diagnosis(case: str, result, oracle_after: float = math.nan) -> Answer:
    """The answer of a :class:`~calibrax.diagnosis.Diagnosis` (its gaps as the diagnosis states them:
    a case answered "none" keeps its gap, shrinkage 0)."""
    models = result.ranking.models
    return Answer(case, result.verdict, tuple(m.name for m in models), {m.name: m.probability for m in models},
                  {m.name: dict(m.effect_mean) for m in models if m.effect_mean}, result.gap_before, result.gap_after,
                  oracle_after, _recovered(result), tuple(result.final.unexplained), len(result.judge_on),
                  result.final.best_candidate, tuple(f"{c.effect}: {c.outcome}" for c in result.final.confirmations))


def _recovered(result) -> dict[str, float]:
    """The named effect's value as the diagnosis tells the user: the recalibration's, else the
    verdict's design posterior (see :attr:`Answer.recovered`)."""
    values = (result.recalibrated or {}).get("effect_values")
    if values:
        return {k: float(v) for k, v in values.items()}
    model = next((m for m in result.ranking.models if m.name == result.verdict), None)
    return {k: float(v) for k, v in (model.effect_mean if model is not None else {}).items()}


def write_answers(answers: list[Answer], path: Path) -> None:
    path.write_text(json.dumps({"answers": [a.to_dict() for a in answers]}, indent=1, default=_plain))


def read_answers(path: Path) -> list[Answer]:
    try:
        return [Answer.from_dict(d) for d in json.loads(Path(path).read_text())["answers"]]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ConfigError("--answers", f"{path}: not an answers file written by the benchmark ({exc})") from None


def _plain(v: Any) -> Any:
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    raise TypeError(type(v))


@dataclass
class Scores:
    """The benchmark's scores (see the module docstring); rates are NaN where no case counts."""

    classes: list[str]
    verdicts: list[str]
    confusion: np.ndarray                       # (classes, verdicts) counts
    top1: dict[str, float]                      # by magnitude level, and "medium+large", "all"
    top2: dict[str, float]
    counts: dict[str, int]                      # cases per top-1 key
    false_alarms: float
    n_none: int
    unlisted_rejected: float
    n_unlisted: int
    magnitude_error: float                      # median relative error
    magnitude_errors: list[float]
    shrinkage_ratio: float                      # median diagnosis/oracle shrinkage over listed cases
    shrinkage_ratios: list[float]
    per_case: list[dict[str, Any]] = field(default_factory=list)
    #: top-1 over medium and large per listed class, and the counts
    top1_by_class: dict[str, float] = field(default_factory=dict)
    counts_by_class: dict[str, int] = field(default_factory=dict)
    #: the median shrinkage ratio per listed class, and the cases it counts
    shrinkage_by_class: dict[str, float] = field(default_factory=dict)
    shrinkage_counts: dict[str, int] = field(default_factory=dict)
    #: listed + unlisted together: the listed one named; named with the gap flagged; cases
    mixed_named: float = math.nan
    mixed_flagged: float = math.nan
    n_mixed: int = 0
    #: the same per listed effect: {effect: (named, named and flagged, cases)}
    mixed_by_effect: dict[str, tuple[float, float, int]] = field(default_factory=dict)
    #: the mismatch cases per kind and "all": {kind: {score: (rate, cases)}}, scores
    #: ``false alarms``, ``none of the candidates (beyond)``, ``none (inside)``, ``listed named``
    mismatch: dict[str, dict[str, tuple[float, int]]] = field(default_factory=dict)

    def goals(self) -> list[tuple[str, bool | None]]:
        """Each goal met (True), not met (False) or without a case to judge it (None)."""
        def judged(value: float, ok: bool) -> bool | None:
            return None if not math.isfinite(value) else ok

        top1 = self.top1.get("medium+large", math.nan)
        out = [(f"top-1 over medium and large ≥ {GOAL_TOP1:.0%}", judged(top1, top1 >= GOAL_TOP1))]
        out += [(f"top-1 over medium and large, {k}, ≥ {GOAL_TOP1:.0%}", judged(v, v >= GOAL_TOP1))
                for k, v in self.top1_by_class.items()]
        out += [(f"false alarms ≤ {GOAL_FALSE_ALARMS:.0%}", judged(self.false_alarms, self.false_alarms <= GOAL_FALSE_ALARMS)),
                (f"an unlisted effect alone answered \"none of the candidates\" ≥ {GOAL_UNLISTED:.0%}",
                 judged(self.unlisted_rejected, self.unlisted_rejected >= GOAL_UNLISTED)),
                (f"median shrinkage ≥ {GOAL_SHRINKAGE:.0%} of the oracle's",
                 judged(self.shrinkage_ratio, self.shrinkage_ratio >= GOAL_SHRINKAGE))]
        out += [(f"median shrinkage, {k}, ≥ {GOAL_SHRINKAGE:.0%} of the oracle's",
                 judged(v if self.shrinkage_counts.get(k, 0) >= MIN_SHRINKAGE_CASES else math.nan, v >= GOAL_SHRINKAGE))
                for k, v in self.shrinkage_by_class.items()]
        together = self.mismatch.get("all", {})
        if together:
            fa, rejected = together["false alarms"][0], together["none of the candidates (beyond)"][0]
            out += [(f"mismatch false alarms ≤ {GOAL_MISMATCH_FALSE_ALARMS:.0%}",
                     judged(fa, fa <= GOAL_MISMATCH_FALSE_ALARMS)),
                    (f"a mismatch beyond the noise answered \"none of the candidates\" ≥ {GOAL_MISMATCH_REJECTED:.0%}",
                     judged(rejected, rejected >= GOAL_MISMATCH_REJECTED))]
        return out


def score(labels: list[CaseLabel], answers: list[Answer]) -> Scores:
    """Score answers against labels (cases without an answer are left out of every count)."""
    by_case = {a.case: a for a in answers}
    rows = [(lab, by_case[lab.case]) for lab in labels if lab.case in by_case]
    listed = [(lab, a) for lab, a in rows if lab.klass not in OTHER_CLASSES]
    classes = sorted({lab.klass for lab, _ in listed}) + [k for k in OTHER_CLASSES
                                                          if any(lab.klass == k for lab, _ in rows)]
    effects = sorted({lab.klass for lab, _ in listed} | {a.verdict for _, a in rows} - {NO_EFFECT, NONE_OF_THEM})
    verdicts = effects + [NO_EFFECT, NONE_OF_THEM]
    confusion = np.zeros((len(classes), len(verdicts)), dtype=int)
    for lab, a in rows:
        confusion[classes.index(lab.klass), verdicts.index(a.verdict)] += 1
    top1, top2, counts = {}, {}, {}
    for key, keep in (("small", lambda lab: lab.magnitude == "small"), ("medium", lambda lab: lab.magnitude == "medium"),
                      ("large", lambda lab: lab.magnitude == "large"),
                      ("medium+large", lambda lab: lab.magnitude in ("medium", "large")), ("all", lambda lab: True)):
        sel = [(lab, a) for lab, a in listed if keep(lab)]
        counts[key] = len(sel)
        top1[key] = _rate([a.verdict == lab.expected for lab, a in sel])
        top2[key] = _rate([a.verdict == lab.expected or lab.expected in a.ranked[:2] for lab, a in sel])
    by_class, by_class_n = {}, {}
    for k in sorted({lab.klass for lab, _ in listed}):
        sel = [(lab, a) for lab, a in listed if lab.klass == k and lab.magnitude in ("medium", "large")]
        by_class[k], by_class_n[k] = _rate([a.verdict == lab.expected for lab, a in sel]), len(sel)
    nones = [a for lab, a in rows if lab.klass == CLASS_NONE]
    unlisted = [a for lab, a in rows if lab.klass == CLASS_UNLISTED]
    mixed = [(lab, a) for lab, a in rows if lab.klass == CLASS_MIXED]
    errors = []
    for lab, a in listed:
        if a.verdict == lab.expected:
            for name, truth in lab.effects.items():
                got = a.magnitude.get(name)
                if got is not None and truth != 0:
                    errors.append(abs(got - truth) / abs(truth))
    ratios, ratios_by_class = [], {k: [] for k in sorted({lab.klass for lab, _ in listed})}
    for lab, a in listed:
        if (math.isfinite(a.oracle_shrinkage) and a.oracle_shrinkage >= MIN_ORACLE_SHRINKAGE
                and a.gap_before >= noise_gap_limit(a.held_out)):
            mine = a.shrinkage if math.isfinite(a.shrinkage) else 0.0
            ratios.append(mine / a.oracle_shrinkage)
            ratios_by_class.setdefault(lab.klass, []).append(ratios[-1])
    per_case = [{"case": lab.case, "class": lab.klass, "magnitude": lab.magnitude, "truth_backend": lab.truth_backend,
                 "expected": lab.expected, "verdict": a.verdict, "p": a.probabilities.get(a.verdict, math.nan),
                 "shrinkage": a.shrinkage, "oracle_shrinkage": a.oracle_shrinkage,
                 "unexplained": list(a.unexplained)} for lab, a in rows]
    return Scores(classes, verdicts, confusion, top1, top2, counts,
                  _rate([a.verdict != NO_EFFECT for a in nones]), len(nones),
                  _rate([a.verdict == NONE_OF_THEM for a in unlisted]), len(unlisted),
                  float(np.median(errors)) if errors else math.nan, errors,
                  float(np.median(ratios)) if ratios else math.nan, ratios, per_case, by_class, by_class_n,
                  {k: float(np.median(v)) if v else math.nan for k, v in sorted(ratios_by_class.items())},
                  {k: len(v) for k, v in sorted(ratios_by_class.items())},
                  _rate([a.verdict == lab.expected for lab, a in mixed]),
                  _rate([a.verdict == lab.expected and bool(a.unexplained) for lab, a in mixed]), len(mixed),
                  _mixed_by_effect(mixed), _mismatch_scores(rows))


def _mismatch_scores(rows: list[tuple[CaseLabel, Answer]]) -> dict[str, dict[str, tuple[float, int]]]:
    """The mismatch cases' scores per kind and over all kinds (see :attr:`Scores.mismatch`)."""
    cases = [(lab, a) for lab, a in rows if lab.klass in MISMATCH_CLASSES]
    out = {}
    for kind in sorted({lab.mismatch for lab, _ in cases}) + ["all"] if cases else ():
        sel = [(lab, a) for lab, a in cases if kind in ("all", lab.mismatch)]
        alone = [(lab, a) for lab, a in sel if lab.klass == CLASS_MISMATCH]
        beyond = [a for lab, a in alone if lab.expected == NONE_OF_THEM]
        inside = [a for lab, a in alone if lab.expected == NO_EFFECT]
        either = [a for lab, a in alone if lab.expected not in (NO_EFFECT, NONE_OF_THEM)]
        listed = [(lab, a) for lab, a in sel if lab.klass == CLASS_MISMATCH_LISTED]
        out[kind] = {"false alarms": (_rate([a.verdict not in (NO_EFFECT, NONE_OF_THEM) for _, a in alone]), len(alone)),
                     "none of the candidates (beyond)": (_rate([a.verdict == NONE_OF_THEM for a in beyond]), len(beyond)),
                     "none (inside)": (_rate([a.verdict == NO_EFFECT for a in inside]), len(inside)),
                     "none of the candidates (borderline)": (_rate([a.verdict == NONE_OF_THEM for a in either]),
                                                             len(either)),
                     "listed named": (_rate([a.verdict == lab.expected for lab, a in listed]), len(listed))}
    return out


def _mixed_by_effect(mixed: list[tuple[CaseLabel, Answer]]) -> dict[str, tuple[float, float, int]]:
    out = {}
    for effect in sorted({lab.expected for lab, _ in mixed}):
        sel = [(lab, a) for lab, a in mixed if lab.expected == effect]
        out[effect] = (_rate([a.verdict == effect for _, a in sel]),
                       _rate([a.verdict == effect and bool(a.unexplained) for _, a in sel]), len(sel))
    return out


def _rate(flags: list[bool]) -> float:
    return float(np.mean(flags)) if flags else math.nan


def _pct(v: float) -> str:
    return "–" if not math.isfinite(v) else f"{100 * v:.0f} %"


def table(scores: Scores, title: str = "") -> str:
    """The scores as markdown: the summary, the goals and the confusion matrix."""
    s = scores
    lines = [f"### {title}" if title else "", "", "| score | value | cases |", "|---|---|---|"]
    for key in ("small", "medium", "large", "medium+large", "all"):
        lines.append(f"| top-1, {key} | {_pct(s.top1[key])} | {s.counts[key]} |")
    for k, v in s.top1_by_class.items():
        lines.append(f"| top-1, medium+large, {k} | {_pct(v)} | {s.counts_by_class[k]} |")
    lines.append(f"| top-2, medium+large | {_pct(s.top2['medium+large'])} | {s.counts['medium+large']} |")
    lines.append(f"| false alarms (no-effect cases not answered \"none\") | {_pct(s.false_alarms)} | {s.n_none} |")
    lines.append(f"| an unlisted effect alone answered \"none of the candidates\" | {_pct(s.unlisted_rejected)} | {s.n_unlisted} |")
    if s.n_mixed:
        lines.append(f"| listed + unlisted: the listed one named | {_pct(s.mixed_named)} | {s.n_mixed} |")
        lines.append(f"| listed + unlisted: named, and the gap it leaves flagged | {_pct(s.mixed_flagged)} | {s.n_mixed} |")
        for k, (named, flagged, n) in s.mixed_by_effect.items():
            lines.append(f"| listed + unlisted, {k} + the unlisted one: named; named and flagged | "
                         f"{_pct(named)}; {_pct(flagged)} | {n} |")
    for kind, row in s.mismatch.items():
        words = {"false alarms": "a listed effect named (false alarm)",
                 "none of the candidates (beyond)": "beyond the noise: \"none of the candidates\"",
                 "none (inside)": "inside the noise: \"none\"",
                 "none of the candidates (borderline)": "at the noise's edge (either answer right): \"none of the "
                                                        "candidates\"",
                 "listed named": "with a listed effect on top: it named"}
        for key, (rate, n) in row.items():
            if n:
                lines.append(f"| mismatch, {kind.replace('_', ' ')}: {words[key]} | {_pct(rate)} | {n} |")
    lines.append(f"| magnitude error, median relative (of the value the diagnosis tells: the recalibration's) | "
                 f"{_pct(s.magnitude_error)} | {len(s.magnitude_errors)} |")
    lines.append(f"| shrinkage / oracle's, median (held-out gap before beyond seed noise's {GAP_NOISE_QUANTILE:.0%} "
                 f"quantile, oracle shrinks it ≥ {MIN_ORACLE_SHRINKAGE:.0%}) | {_pct(s.shrinkage_ratio)} | "
                 f"{len(s.shrinkage_ratios)} |")
    for k, v in s.shrinkage_by_class.items():
        few = (f" (fewer than {MIN_SHRINKAGE_CASES} cases whose held-out features show the effect: not judged)"
               if s.shrinkage_counts[k] < MIN_SHRINKAGE_CASES else "")
        lines.append(f"| shrinkage / oracle's, {k}{few} | {_pct(v)} | {s.shrinkage_counts[k]} |")
    verdict = {True: "met", False: "NOT met", None: "not judged (too few cases)"}
    lines += ["", "Goals: " + "; ".join(f"{name}: {verdict[ok]}" for name, ok in s.goals()), "",
              "| class \\ verdict | " + " | ".join(s.verdicts) + " |", "|---" * (len(s.verdicts) + 1) + "|"]
    for i, k in enumerate(s.classes):
        lines.append(f"| {k} | " + " | ".join(str(int(v)) for v in s.confusion[i]) + " |")
    return "\n".join(lines).lstrip("\n") + "\n"


def confusion_figure(scores: Scores, path: Path, title: str = "") -> Path:
    """The confusion matrix as a heat map (rows normalised), counts written in the cells."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    c = scores.confusion.astype(float)
    share = c / np.maximum(c.sum(axis=1, keepdims=True), 1)
    fig, ax = plt.subplots(figsize=(1.4 * len(scores.verdicts) + 2.5, 0.7 * len(scores.classes) + 2))
    ax.imshow(share, cmap="Blues", vmin=0, vmax=1)
    ax.set_xticks(range(len(scores.verdicts)), [v.replace("none of the candidates", "none of\nthe candidates")
                                                 for v in scores.verdicts], rotation=30, ha="right")
    ax.set_yticks(range(len(scores.classes)), scores.classes)
    for i in range(c.shape[0]):
        for j in range(c.shape[1]):
            ax.text(j, i, f"{int(c[i, j])}", ha="center", va="center", color="white" if share[i, j] > 0.6 else "black")
    ax.set_xlabel("verdict")
    ax.set_ylabel("hidden (class)")
    import textwrap

    ax.set_title(textwrap.fill(title or "diagnosis benchmark: confusion matrix", 60), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
