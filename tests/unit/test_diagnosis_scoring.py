"""The diagnosis's scoring on synthetic feature responses with known answers (no simulator).

A known linear world: six features respond to two calibrated parameters, and each of three
candidate effects moves its own pattern of features (wall friction raises the frictions and
lowers the density, cohesion raises the low-stress peaks most, the size distribution raises the
density only). Every simulation carries unit seed noise.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrax.diagnosis.effects import UniformPrior
from calibrax.diagnosis.scoring import NO_EFFECT, NONE_OF_THEM, CandidateSpace, Design, Emulator, Target, rank

F = 6
BASE = np.array([10.0, 20.0, 30.0, 40.0, 50.0, 60.0])
SLOPES = np.array([[3.0, 0.5], [2.5, 1.0], [1.0, 2.0], [0.5, 3.0], [0.0, 1.0], [1.0, 0.0]])   # (F, d)
PATTERNS = {   # each effect at full magnitude, in seed s.d.
    "wall": np.array([6.0, 6.0, 3.0, 0.0, -6.0, 0.0]),
    "cohesion": np.array([0.0, 0.0, 2.0, 8.0, 0.0, 0.0]),
    "psd": np.array([0.0, 0.0, 0.0, 0.0, 7.0, 0.0]),
}
EFFECTS = list(PATTERNS)


def world(unit: np.ndarray, effects: np.ndarray) -> np.ndarray:
    """Mean features at scaled calibrated parameters (n, 2) and effect fractions (n, 3)."""
    out = BASE + unit @ SLOPES.T
    for k, name in enumerate(EFFECTS):
        out = out + np.outer(effects[:, k] * (1.2 - 0.2 * effects[:, k]), PATTERNS[name])
    return out


def synthetic_design(rng: np.random.Generator, per_effect: int = 10) -> Design:
    unit = [np.zeros(2)] * 4 + list(rng.uniform(-1, 1, (4, 2)))
    eff = [np.zeros(3)] * 8
    for k in range(3):
        for _ in range(per_effect):
            unit.append(rng.uniform(-1, 1, 2))
            e = np.zeros(3)
            e[k] = rng.uniform(0, 1)
            eff.append(e)
    unit, eff = np.array(unit), np.array(eff)
    y = world(unit, eff) + rng.normal(0, 1, (unit.shape[0], F))
    return Design(unit, eff, tuple(EFFECTS), y, tuple(f"f{j}" for j in range(F)))


def experiment(rng: np.random.Generator, unit: np.ndarray, effects: np.ndarray, shift: np.ndarray | None = None,
               n: int = 3) -> Target:
    reps = world(np.repeat(unit[None], n, 0), np.repeat(effects[None], n, 0)) + rng.normal(0, 1, (n, F))
    if shift is not None:
        reps = reps + shift
    return Target(reps.mean(axis=0), reps.std(axis=0, ddof=1), n)


CANDIDATES = [CandidateSpace(name, name, (name,), (0.0,), (1.0,), (UniformPrior(0.0, 1.0),)) for name in EFFECTS]


@pytest.mark.parametrize("truth", EFFECTS)
def test_an_effect_that_explains_the_gap_wins(truth: str) -> None:
    rng = np.random.default_rng(1)
    design = synthetic_design(rng)
    eff = np.zeros(3)
    eff[EFFECTS.index(truth)] = 0.8
    ranking = rank(experiment(rng, np.array([0.3, -0.2]), eff), design, CANDIDATES)
    assert ranking.verdict == truth, ranking.reason
    assert ranking.models[0].probability > 0.9
    assert sum(m.probability for m in ranking.models) == pytest.approx(1.0)
    best = ranking.model(truth)
    assert best.effect_interval[truth][0] < 0.8 < best.effect_interval[truth][1]


def test_a_noise_level_gap_gives_no_effect() -> None:
    hits = 0
    for seed in range(5):
        rng = np.random.default_rng(10 + seed)
        design = synthetic_design(rng)
        ranking = rank(experiment(rng, np.array([-0.4, 0.5]), np.zeros(3)), design, CANDIDATES, seed=seed)
        hits += ranking.verdict == NO_EFFECT
        assert ranking.verdict != NONE_OF_THEM, ranking.reason
    assert hits >= 4


def test_a_gap_no_candidate_can_make_gives_none_of_the_candidates() -> None:
    rng = np.random.default_rng(3)
    design = synthetic_design(rng)
    # feature 5 moves with no effect and only weakly with the parameters: 12 s.d. below the box
    shift = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -12.0])
    ranking = rank(experiment(rng, np.zeros(2), np.zeros(3), shift), design, CANDIDATES)
    assert ranking.verdict == NONE_OF_THEM
    assert "f5" in ranking.reason


def test_a_listed_effect_beside_an_unlisted_one_is_named_and_the_gap_it_leaves_flagged() -> None:
    """Wall friction at 0.8 with a gap in f5 that no candidate makes (issue 34): the wall explains
    most of the gap and is named; f5, which it leaves, is flagged. The same f5 gap alone (the test
    above) flags nothing: there no candidate explains without making a new misfit."""
    rng = np.random.default_rng(3)
    design = synthetic_design(rng)
    shift = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -12.0])
    ranking = rank(experiment(rng, np.zeros(2), np.array([0.8, 0.0, 0.0]), shift), design, CANDIDATES)
    assert ranking.verdict == "wall", ranking.reason
    assert ranking.unexplained == ("f5",) and ranking.gap_left
    assert "acts beside it" in ranking.reason
    alone = rank(experiment(rng, np.zeros(2), np.zeros(3), shift), design, CANDIDATES)
    assert alone.verdict == NONE_OF_THEM and not alone.gap_left


def test_a_measured_prior_moves_the_evidence() -> None:
    """A prior that puts the wall friction where the data want it raises its evidence over a flat
    prior; one far from it lowers it (the Bayes factor's Occam factor at work)."""
    from calibrax.diagnosis.effects import TruncatedNormalPrior
    from calibrax.diagnosis.scoring import Emulator, score_model

    rng = np.random.default_rng(4)
    design = synthetic_design(rng)
    target = experiment(rng, np.zeros(2), np.array([0.5, 0.0, 0.0]))
    emulator = Emulator.fit(design)
    flat = score_model(target, emulator, CANDIDATES[0])
    right = CandidateSpace("wall", "wall", ("wall",), (0.0,), (1.0,), (TruncatedNormalPrior(0.5, 0.05, 0.0, 1.0),))
    wrong = CandidateSpace("wall", "wall", ("wall",), (0.0,), (1.0,), (TruncatedNormalPrior(0.05, 0.02, 0.0, 1.0),))
    assert score_model(target, emulator, right).log_evidence > flat.log_evidence
    assert score_model(target, emulator, wrong).log_evidence < flat.log_evidence


def test_a_wider_prior_pays_for_its_flexibility() -> None:
    """The marginal likelihood, not the best fit, decides (issue 48): two priors that both hold the
    truth fit it equally well at their best, and the one four times wider loses about ln 4 of log
    evidence (the likelihood lies inside the narrower); a log-uniform prior over two decades, which puts little weight where the data are,
    loses more than the flat one."""
    import math

    from calibrax.diagnosis.effects import LogUniformPrior
    from calibrax.diagnosis.scoring import Emulator, score_model

    rng = np.random.default_rng(5)
    design = synthetic_design(rng)
    target = experiment(rng, np.zeros(2), np.array([0.5, 0.0, 0.0]))
    emulator = Emulator.fit(design)

    def space(prior: object) -> CandidateSpace:
        return CandidateSpace("wall", "wall", ("wall",), (0.0,), (1.0,), (prior,))

    flat, wide = score_model(target, emulator, space(UniformPrior(0.0, 1.0))), score_model(
        target, emulator, space(UniformPrior(0.0, 4.0)))
    assert wide.chi2 == pytest.approx(flat.chi2, abs=0.01), "both priors hold the best fit"
    assert flat.log_evidence - wide.log_evidence == pytest.approx(math.log(4.0), abs=0.2)
    log_scaled = score_model(target, emulator, space(LogUniformPrior(0.01, 1.0)))
    assert log_scaled.log_evidence < flat.log_evidence - 0.5
    assert LogUniformPrior(0.01, 1.0).ppf(np.array([0.0, 0.5, 1.0])) == pytest.approx([0.01, 0.1, 1.0])


def test_the_emulator_bends_only_where_the_response_does() -> None:
    """Quadratic terms in the calibrated parameters join when left-out simulations say so."""
    from calibrax.diagnosis.scoring import Emulator

    rng = np.random.default_rng(7)
    design = synthetic_design(rng, per_effect=12)
    assert not Emulator.fit(design).quadratic
    bent = design.features + 6.0 * design.unit[:, :1] ** 2       # saturating in the first parameter
    curved = Design(design.unit, design.effects, design.effect_columns, bent, design.names)
    emulator = Emulator.fit(curved)
    assert emulator.quadratic
    assert np.all(emulator.sd < 1.5)                               # back to the seed noise (1)


def test_across_fidelities_the_emulator_reads_the_target_through_the_shift() -> None:
    """The design at a cheap level whose features sit a known shift away from the target's, and a
    few target simulations at the calibrated point: the emulator learns the shift, so the effect
    behind the experiment (made at the target) is named, and its size recovered."""
    rng = np.random.default_rng(4)
    level_shift = np.array([-4.0, 4.0, -4.0, 4.0, 0.0, 0.0])     # cheap − target, in seed s.d.
    cheap = synthetic_design(rng)
    cheap = Design(cheap.unit, cheap.effects, cheap.effect_columns, cheap.features + level_shift, cheap.names)
    centre = np.zeros((3, 2))
    at_target = world(centre, np.zeros((3, 3))) + rng.normal(0, 1, (3, F))
    design = Design(np.vstack([cheap.unit, centre]), np.vstack([cheap.effects, np.zeros((3, 3))]), cheap.effect_columns,
                    np.vstack([cheap.features, at_target]), cheap.names,
                    np.r_[np.zeros(len(cheap.unit), bool), np.ones(3, bool)])
    eff = np.zeros(3)
    eff[EFFECTS.index("psd")] = 0.8
    target = experiment(rng, np.array([0.3, -0.2]), eff)
    emulator = Emulator.fit(design)
    assert emulator.shifted and design.two_levels and not cheap.two_levels
    mu, h = emulator.predict(np.zeros((1, 2)), np.zeros((1, 3)))
    assert np.all(np.abs(mu[0] - world(np.zeros((1, 2)), np.zeros((1, 3)))[0]) < 2.0)
    ranking = rank(target, design, CANDIDATES, emulator=emulator)
    assert ranking.verdict == "psd", ranking.reason
    lo, hi = ranking.model("psd").effect_interval["psd"]
    assert lo < 0.8 < hi
    # the shift is the basis's last regressor: target − cheap, recovered within the noise of three seeds
    assert np.all(np.abs(emulator.coef[-1] + level_shift) < 2.0), emulator.coef[-1]


def _two_level_design(rng: np.random.Generator, scale: float, level_point: bool) -> Design:
    """A cheap design and, at the target (both with unit seed noise), three replicates
    at the calibrated point and, with ``level_point``, one simulation there with the wall at half
    its range; the target's wall acts as ``scale`` × the cheap level's, its features sit 4 s.d.
    lower."""
    cheap = synthetic_design(rng)
    n_cheap = len(cheap.unit)
    target_eff = np.zeros((4 if level_point else 3, 3))
    if level_point:
        target_eff[3, EFFECTS.index("wall")] = 0.5
    centre = np.zeros((len(target_eff), 2))
    at_target = world(centre, target_eff * scale) - 4.0 + rng.normal(0, 1, (len(target_eff), F))
    groups = np.r_[np.zeros(4, int), np.arange(1, n_cheap - 3), [n_cheap] * 3, [n_cheap + 1] * level_point]
    return Design(np.vstack([cheap.unit, centre]), np.vstack([cheap.effects, target_eff]), cheap.effect_columns,
                  np.vstack([cheap.features, at_target]), cheap.names,
                  np.r_[np.zeros(n_cheap, bool), np.ones(len(target_eff), bool)], groups)


def test_across_fidelities_one_point_at_the_target_gives_an_effects_scale_there() -> None:
    """An effect whose signature at the target is 0.4 of the cheap level's (a rough wall
    drags a small cell's whole bed, a large cell's shear band only): the shift alone reads the
    target's wall as a weak one, so the truth falls outside its interval; one simulation at the
    target with the wall on gives the scale, and the interval holds the truth again."""
    scale, truth = 0.4, 0.8
    eff = np.zeros(3)
    eff[EFFECTS.index("wall")] = truth

    def target(rng: np.random.Generator) -> Target:
        reps = world(np.zeros((3, 2)), np.repeat(eff[None] * scale, 3, 0)) - 4.0 + rng.normal(0, 1, (3, F))
        return Target(reps.mean(axis=0), reps.std(axis=0, ddof=1), 3)

    shifted = Emulator.fit(_two_level_design(np.random.default_rng(5), scale, level_point=False))
    assert shifted.level_scale is None
    rng = np.random.default_rng(5)
    design = _two_level_design(rng, scale, level_point=True)
    measured = target(rng)
    lo, hi = rank(measured, design.only(list(range(F))), CANDIDATES, emulator=shifted).model("wall").effect_interval["wall"]
    assert hi < truth, (lo, hi)
    emulator = Emulator.fit(design)
    assert emulator.level_scale[EFFECTS.index("wall")] == pytest.approx(scale, rel=0.25)
    assert emulator.level_scale[EFFECTS.index("psd")] == 1.0
    ranking = rank(measured, design, CANDIDATES, emulator=emulator)
    assert ranking.verdict == "wall", ranking.reason
    lo, hi = ranking.model("wall").effect_interval["wall"]
    assert lo < truth < hi, (lo, hi)


def test_a_misfitting_emulator_is_told_from_seed_noise_by_the_pure_error() -> None:
    """A response beyond the quadratic (an effect that takes off near the end of its range, as a
    rough wall's peak τ/σ does at `tiny`): the residual s.d. holds the misfit, the replicates'
    scatter does not; the lack-of-fit test flags that feature alone, and its noise is the pure
    error. With the default design's four replicates (3 degrees of freedom) the test at 1 % needs
    a residual s.d. about five times the pure error: here 8.6 against 1.0 (at `converged` with a
    rough wall, 0.47 against 0.075)."""
    rng = np.random.default_rng(2)
    design = synthetic_design(rng, per_effect=12)
    groups = np.r_[np.zeros(4, int), np.arange(1, len(design.unit) - 3)]
    bent = design.features.copy()
    bent[:, 0] += 200.0 * design.effects[:, EFFECTS.index("wall")] ** 8
    emulator = Emulator.fit(Design(design.unit, design.effects, design.effect_columns, bent, design.names,
                                   None, groups))
    assert emulator.misfit[0] and not emulator.misfit[1:].any(), emulator.lack_of_fit_p
    assert emulator.sd[0] > 5.0
    assert emulator.noise_sd[0] == pytest.approx(emulator.pure_sd[0]) and emulator.noise_sd[0] < 2.0
    assert np.array_equal(emulator.noise_sd[1:], emulator.sd[1:])
    assert emulator.discrepancy_sd[0] > 5.0 and not emulator.discrepancy_sd[1:].any()


#: the target's world where its shapes differ from the cheap level's (at `converged` a rough wall
#: raises the bulk density, at `tiny` it lowers it): the density-like feature f4 falls with the
#: second calibrated parameter at the target (it rises at the cheap level), and the wall's
#: signature there raises it
TARGET_SLOPES = SLOPES * np.array([[1.0], [1.0], [1.0], [1.0], [-3.0], [1.0]])
TARGET_WALL = np.array([5.0, 5.0, 2.5, 0.0, 8.0, -3.0])


def _target_world(unit: np.ndarray, wall: np.ndarray) -> np.ndarray:
    return BASE - 4.0 + unit @ TARGET_SLOPES.T + np.outer(wall * (1.2 - 0.2 * wall), TARGET_WALL)


def test_the_target_spans_a_direction_only_where_its_simulations_spread() -> None:
    from calibrax.diagnosis.scoring import spanned_directions

    assert spanned_directions(np.zeros((3, 2))).shape == (0, 2)
    (v,) = spanned_directions(np.array([[0.0, 0.0], [0.0, 0.0], [0.3, 0.6], [0.3, 0.6]]))
    assert abs(abs(v @ np.array([0.3, 0.6]) / np.hypot(0.3, 0.6)) - 1.0) < 1e-9


def test_the_target_reads_its_own_slope_and_an_effects_own_signature_from_its_simulations() -> None:
    """A design at the cheap level; at the target 3 replicates at the calibrated point, a refit of
    the model without an effect (2 seeds at another calibrated point: refuted there, it joins the
    design) and the wall's point (1 seed at half its range). The target's density falls with the
    calibrated parameter where the cheap level's rises, and the wall raises it where the cheap
    level's lowers it: one scale λ cannot carry that. The emulator gives the target its own slope
    along the refit's direction and reads the wall's signature per feature from its point, so the
    wall behind the experiment is named with its size inside the interval."""
    rng = np.random.default_rng(7)
    cheap = synthetic_design(rng)
    n_cheap = len(cheap.unit)
    refit = np.array([0.0, 0.6])
    unit_t = np.array([[0.0, 0.0]] * 3 + [refit] * 2 + [[0.0, 0.0]])
    wall_t = np.array([0.0] * 5 + [0.5])
    eff_t = np.zeros((6, 3))
    eff_t[:, EFFECTS.index("wall")] = wall_t
    y_t = _target_world(unit_t, wall_t) + rng.normal(0, 1, (6, F))
    groups = np.r_[np.zeros(4, int), np.arange(1, n_cheap - 3), [n_cheap] * 3, [n_cheap + 1] * 2, [n_cheap + 2]]
    design = Design(np.vstack([cheap.unit, unit_t]), np.vstack([cheap.effects, eff_t]), cheap.effect_columns,
                    np.vstack([cheap.features, y_t]), cheap.names, np.r_[np.zeros(n_cheap, bool), np.ones(6, bool)],
                    groups)
    emulator = Emulator.fit(design)
    assert emulator.target_directions.shape == (1, 2)
    assert emulator.own_signature[EFFECTS.index("wall")] and not emulator.own_signature[EFFECTS.index("psd")]
    # the target's own slope of f4 along the refit, not the cheap level's
    mu, _ = emulator.predict(np.array([[0.0, 0.0], refit]), np.zeros((2, 3)))
    assert (mu[1, 4] - mu[0, 4]) < -0.5 * 3.0 * 0.6, mu[:, 4]
    truth = 0.6
    reps = _target_world(np.zeros((3, 2)), np.full(3, truth)) + rng.normal(0, 1, (3, F))
    measured = Target(reps.mean(axis=0), reps.std(axis=0, ddof=1), 3)
    ranking = rank(measured, design, CANDIDATES, emulator=emulator)
    assert ranking.verdict == "wall", ranking.reason
    lo, hi = ranking.model("wall").effect_interval["wall"]
    assert lo < truth < hi, (lo, hi)
