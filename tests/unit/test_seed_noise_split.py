"""benchmarks/seed_noise.py's split of a feature's seed scatter into what the pour leaves (shared by
every step of one test) and what the shearing adds (step to step)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import seed_noise  # noqa: E402


def _tests(seed_sd: float, step_sd: float, seeds: int = 4000, steps: int = 4) -> np.ndarray:
    rng = np.random.default_rng(7)
    step_means = np.array([0.9, 0.85, 0.8, 0.75])[:steps]  # steps at different σ differ in mean
    return step_means + rng.normal(0.0, seed_sd, (seeds, 1)) + rng.normal(0.0, step_sd, (seeds, steps))


@pytest.mark.parametrize("seed_sd, step_sd", [(0.05, 0.1), (0.1, 0.02), (0.0, 0.08)])
def test_the_split_recovers_both_parts(seed_sd, step_sd):
    got_seed, got_step = seed_noise.variance_split(_tests(seed_sd, step_sd))
    assert got_step == pytest.approx(step_sd, rel=0.03)
    assert got_seed == pytest.approx(seed_sd, abs=0.006)


def test_the_step_means_do_not_count_as_scatter():
    same = np.tile([0.9, 0.8, 0.7, 0.6], (10, 1))
    assert seed_noise.variance_split(same) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_too_few_seeds_or_steps_give_nan():
    assert all(np.isnan(seed_noise.variance_split(np.ones((1, 4)))))
    assert all(np.isnan(seed_noise.variance_split(np.ones((5, 1)))))


def test_the_sd_interval_covers_the_true_sd_about_as_often_as_it_says():
    rng = np.random.default_rng(3)
    draws = rng.normal(0.8, 0.06, (2000, 10))
    bounds = np.array([seed_noise.sd_interval(d, 0.9) for d in draws])
    covered = np.mean((bounds[:, 0] <= 0.06) & (0.06 <= bounds[:, 1]))
    assert covered == pytest.approx(0.9, abs=0.025)
    lo, hi = seed_noise.sd_interval(draws[0])
    assert lo < np.std(draws[0], ddof=1) < hi
    assert all(np.isnan(seed_noise.sd_interval(np.array([0.8]))))
