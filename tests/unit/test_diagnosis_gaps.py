"""A diagnosis that names no effect recalibrates nothing: its held-out gap after is the gap before,
its shrinkage 0, the same in diagnosis.json as in the benchmark's answers (issue 36)."""

from __future__ import annotations

import pytest

from calibrax.diagnosis.benchmark.scores import answer_from_diagnosis
from calibrax.diagnosis.gap import FeatureGap
from calibrax.diagnosis.run import Diagnosis
from calibrax.diagnosis.scoring import Ranking
from calibrax.diagnosis.verdict import CONFIRMED, Confirmation, Verdict


def _diagnosis(after: list[FeatureGap], recalibrated: dict | None = None) -> Diagnosis:
    before = [FeatureGap("bulk_density", "density", 1500.0, 10.0, 3, 1440.0, 10.0, 4),
              FeatureGap("peak_ratio_9kPa", "peaks", 0.8, 0.05, 3, 0.78, 0.05, 4)]
    if after or recalibrated:
        confirmed = Confirmation("wall_friction", "wall friction", CONFIRMED, 6.0, 0.5, 1.96, 4.0, 8.0, 5.0,
                                 recalibrated=recalibrated or {}, after=tuple(after))
        final = Verdict("wall_friction", "wall friction", None, (confirmed,))
    else:
        final = Verdict("none", "within the noise", None)
    return Diagnosis("analytic_double", ["wall_friction"], {}, ["peaks"], ["bulk_density"],
                     ["bulk_density", "peak_ratio_9kPa"], before, Ranking([], final.name, final.reason), final,
                     {}, 1.0, {}, {})


def test_no_effect_named_keeps_the_gap_and_shrinks_it_by_nothing():
    d = _diagnosis(after=[])
    data = d.to_dict()
    assert data["gap_after"] == data["gap_before"] == pytest.approx(d.gap_before) and d.gap_before > 3
    assert data["shrinkage"] == 0.0 == d.shrinkage
    answer = answer_from_diagnosis("case", d)
    assert (answer.gap_before, answer.gap_after) == (data["gap_before"], data["gap_after"])


def test_a_recalibration_reports_its_own_gap_after():
    after = [FeatureGap("bulk_density", "density", 1500.0, 10.0, 3, 1495.0, 10.0, 4)]
    d = _diagnosis(after)
    assert d.gap_after < d.gap_before and 0 < d.shrinkage < 1
    assert d.to_dict()["shrinkage"] == pytest.approx(1 - d.gap_after / d.gap_before)


def test_the_magnitude_is_scored_on_the_value_the_user_is_told():
    from calibrax.diagnosis.benchmark.scores import Answer

    d = _diagnosis(after=[], recalibrated={"effect": "wall_friction", "effect_values": {"wall_friction": 0.198}})
    answer = answer_from_diagnosis("case", d)
    assert answer.recovered == {"wall_friction": 0.198} and answer.magnitude == {"wall_friction": 0.198}
    # an answers file written before `recovered` was kept falls back to the verdict's design posterior
    old = Answer.from_dict({k: v for k, v in Answer("c", "wall_friction", ("wall_friction",), {"wall_friction": 1.0},
                                                   {"wall_friction": {"wall_friction": 0.158}}, 4.0, 1.0).to_dict().items()
                            if k != "recovered"})
    assert old.magnitude == {"wall_friction": 0.158}


def test_the_locus_is_every_step_of_the_experiments_procedure():
    """The FT4's 3 kPa test's steps are the locus as the paper's are; compressibility is its own
    group, held out by default (where cohesion shows beside the fitted features)."""
    from calibrax.diagnosis.gap import DEFAULT_FIT, GROUPS, candidate_names, group_of

    low = [{"peak_ratio_1kPa": 0.9, "peak_ratio_2kPa": 0.7, "peak_ratio_1.75kPa": 0.75, "bulk_density": 1500.0}]
    names = candidate_names(low)
    assert names[:3] == ("peak_ratio_2kPa", "peak_ratio_1.75kPa", "peak_ratio_1kPa")
    assert {group_of(n) for n in names[:3]} == {"locus"} and "peak_ratio_9kPa" not in names
    assert candidate_names([{"bulk_density": 1500.0}])[:4] == GROUPS["locus"]
    assert group_of("compressibility") == "compressibility" and "compressibility" not in DEFAULT_FIT
    assert group_of("conditioned_bulk_density") == "density"


def test_the_ft4_3kpa_example_gives_its_five_steps_as_the_locus():
    """The documented 3 kPa experiment (docs/reference/experiment-files.md) loads, and the
    diagnosis reads its five steps and its preshears."""
    from pathlib import Path

    from calibrax.core.data.experiment import load_experiment
    from calibrax.diagnosis.gap import candidate_names, group_of, measured

    example = Path(__file__).resolve().parents[2] / "docs" / "_snippets" / "b4c-3kpa.yaml"
    replicates = measured(load_experiment(example), 0.015)
    assert len(replicates) == 3
    locus = [n for n in candidate_names(replicates) if group_of(n) == "locus"]
    assert locus == ["peak_ratio_2kPa", "peak_ratio_1.75kPa", "peak_ratio_1.5kPa", "peak_ratio_1.25kPa", "peak_ratio_1kPa"]
    assert all(0.6 < r["peak_ratio_2kPa"] < 0.8 and 0.6 < r["preshear_ratio"] < 0.75 for r in replicates)


def test_the_report_says_which_signature_the_target_reads_for_itself():
    from calibrax.diagnosis.run import level_words

    words = level_words({"sigma_log": 0.8}, ["wall_friction"])
    assert "sigma_log acts as 0.8 × itself" in words and "wall_friction's signature differs" in words
    assert level_words({}, []) == ""
