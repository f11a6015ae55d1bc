"""The diagnosis's candidate effects, design box, budget split and feature gaps (no simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calibrax import ShearCellSpec
from calibrax.core.data.experiment import Experiment
from calibrax.core.search.parameters import ParameterSpace
from calibrax.diagnosis import effects_by_name
from calibrax.diagnosis.design import LEVEL_POINTS, MIN_HALF_WIDTH, TARGET_RUNS, Box, Budget, design_points, reach_points
from calibrax.diagnosis.effects import TruncatedNormalPrior, UniformPrior
from calibrax.diagnosis.gap import FeatureGap, feature_gaps, parse_groups
from calibrax.errors import ConfigError

SPACE = ParameterSpace.from_config({"youngs_modulus": {"low": 5e9, "high": 5e10, "log": True},
                                    "sliding_friction": {"low": 0.1, "high": 0.9}})


def _experiment(**extra) -> Experiment:
    sig = np.array([9e3, 8e3, 7e3, 6e3])
    return Experiment("e", sig, sig * 0.6, np.ones(4, dtype=int), **extra)


def test_each_builtin_effect_switches_its_own_field_and_off_is_the_plain_model() -> None:
    spec = ShearCellSpec.preset("tiny")
    wall, psd, coh = effects_by_name(["wall_friction", "size_distribution", "cohesion"])
    assert wall.apply(spec, {"wall_friction": 0.3}).geometry.wall_friction == 0.3
    wide = psd.apply(spec, {"sigma_log": 0.25})
    assert wide.size_distribution.kind == "lognormal" and wide.size_distribution.sigma_log == 0.25
    assert psd.apply(spec, {"sigma_log": 0.0}).size_distribution.kind == "mono"
    cohesive = coh.apply(spec, {"bond_number": 0.6})
    assert cohesive.material.bond_number == 0.6 and cohesive.material.cohesion_energy_density == 0.0
    for effect in (wall, psd, coh):
        off = {p.name: p.off for p in effect.parameters}
        assert effect.apply(spec, off).validate().spec_hash() == spec.spec_hash()


def test_a_measured_wall_friction_angle_is_the_wall_frictions_prior() -> None:
    (wall,) = effects_by_name(["wall_friction"])
    assert isinstance(wall.prior(_experiment())["wall_friction"], UniformPrior)
    prior = wall.prior(_experiment(wall_friction_angle_deg=15.0))["wall_friction"]
    assert isinstance(prior, TruncatedNormalPrior)
    assert prior.mean == pytest.approx(math.tan(math.radians(15.0)))
    assert "15°" in prior.describe()
    median = float(prior.ppf(np.array([0.5]))[0])
    assert median == pytest.approx(prior.mean, abs=0.01)


def test_unknown_effects_are_refused_by_name() -> None:
    with pytest.raises(ConfigError, match="--effects.*known"):
        effects_by_name(["wall_friction", "humidity"])


def test_the_box_reaches_past_a_narrow_plausible_region_and_stays_in_bounds() -> None:
    box = Box.around(SPACE, {"youngs_modulus": 2e10, "sliding_friction": 0.85},
                     {"youngs_modulus": (5e9, 5e10), "sliding_friction": (0.84, 0.86)})
    i = SPACE.names.index("sliding_friction")
    assert box.high[i] == pytest.approx(0.9)                          # clipped at the bound
    assert box.low[i] == pytest.approx(0.85 - MIN_HALF_WIDTH * 0.8)   # widened to ±15 % of the range
    j = SPACE.names.index("youngs_modulus")
    assert (box.low[j], box.high[j]) == pytest.approx((5e9, 5e10))    # the plausible region where wider
    corners = box.natural(np.array([[-1.0, -1.0], [1.0, 1.0]]))
    assert np.allclose(box.scaled(corners), [[-1, -1], [1, 1]])


def test_the_design_spends_the_budget_as_stated_with_distinct_seeds() -> None:
    box = Box.around(SPACE, {"youngs_modulus": 2e10, "sliding_friction": 0.35})
    effects = effects_by_name()
    budget = Budget.for_total(36, len(effects))
    assert budget == Budget(4, 4, 8, 4) and budget.total(3) == 36
    points = design_points(box, effects, budget)
    seeds = [s for p in points for s in p.seeds]
    assert len(seeds) == 32 and len(set(seeds)) == 32
    assert points[0].label == "calibrated" and len(points[0].seeds) == 4
    for effect in effects:
        mine = [p for p in points if p.effect == effect.name]
        assert len(mine) == 8
        (param,) = effect.parameters
        values = [p.effect_values[param.name] for p in mine]
        assert min(values) >= param.off and max(values) <= param.high and np.ptp(values) > 0.5 * (param.high - param.off)
    assert Budget.for_total(20, 3) == Budget(3, 3, 3, 3)


def test_a_design_across_fidelities_runs_its_replicates_at_the_target_and_the_rest_cheap() -> None:
    """The target's replicates come first (the gap is measured on design point 0), with seeds of
    their own; every other point runs at the cheap fidelity, with the seeds it has at one fidelity."""
    box = Box.around(SPACE, {"youngs_modulus": 2e10, "sliding_friction": 0.35})
    effects = effects_by_name()
    budget = Budget.for_total(36, len(effects), TARGET_RUNS)
    k = len(effects)
    assert budget == Budget(4, 4, (36 - 8 - 2 * TARGET_RUNS - LEVEL_POINTS) // k, TARGET_RUNS, TARGET_RUNS, LEVEL_POINTS)
    assert 36 - k < budget.total(k) <= 36
    assert Budget.across_fidelities().total(3) == Budget().total(3) + LEVEL_POINTS
    across = design_points(box, effects, budget, cheap="tiny")
    alone = design_points(box, effects, budget)
    assert across[0].label == "calibrated" and across[0].fidelity == "" and len(across[0].seeds) == TARGET_RUNS
    assert all(p.fidelity == "tiny" for p in across[1:]) and across[1].label == "calibrated at tiny"
    assert [p.seeds for p in across[1:]] == [p.seeds for p in alone]
    seeds = [s for p in across for s in p.seeds]
    assert len(seeds) == len(set(seeds))


def test_a_fit_at_the_box_edge_widens_the_box_past_it_and_new_points_fill_the_new_part() -> None:
    """A best fit at the low μs edge (a rough wall compensated by a lower μs) reaches past it by
    the box's own width on that side, within the bounds; a fit inside, or at a bound, does not."""
    box = Box.around(SPACE, {"youngs_modulus": 2e10, "sliding_friction": 0.61})
    i = SPACE.names.index("sliding_friction")
    best = np.zeros(2)
    assert box.reach(best) is None
    best[i] = -1.0
    wider = box.reach(best)
    assert wider.low[i] == pytest.approx(0.61 - 2 * (0.61 - box.low[i]))
    assert wider.high[i] == box.high[i] and np.allclose(np.delete(wider.low, i), np.delete(box.low, i))
    at_bound = Box.around(SPACE, {"youngs_modulus": 2e10, "sliding_friction": 0.15})
    assert at_bound.reach(best) is None or at_bound.reach(best).low[i] == pytest.approx(0.1)
    (wall,) = effects_by_name(["wall_friction"])
    points = reach_points(box, wider, wall, Budget(4, 3, 6, 4), seed=0, cheap="tiny")
    assert [p.effect for p in points] == [None] * 3 + ["wall_friction"] * 6 and {p.fidelity for p in points} == {"tiny"}
    assert all(wider.low[i] <= p.params["sliding_friction"] <= box.low[i] for p in points)
    seeds = [s for p in points for s in p.seeds]
    design_seeds = [s for p in design_points(box, effects_by_name(), Budget()) for s in p.seeds]
    assert len(set(seeds)) == 9 and not set(seeds) & set(design_seeds)


def test_feature_gaps_never_take_the_experiments_spread_below_the_seeds() -> None:
    sims = [{"a": 1.0}, {"a": 1.2}, {"a": 0.8}, {"a": 1.0}]
    exp = [{"a": 2.0}, {"a": 2.0001}, {"a": 1.9999}]
    (gap,) = feature_gaps(sims, exp, ("a",), seed_sd={"a": 0.2})
    assert gap.stderr == pytest.approx(math.sqrt(0.2 ** 2 / 3 + 0.2 ** 2 / 4))
    assert gap.z == pytest.approx(-1.0 / gap.stderr) and gap.implausible
    assert not FeatureGap("b", "flow", 1.0, 0.1, 3, 1.1, 0.1, 4).implausible


@pytest.mark.parametrize("text", ["", "locus,locus", "curves", "locus,density,compressibility,flow,shape"])
def test_fit_groups_are_checked(text: str) -> None:
    with pytest.raises(ConfigError, match="--fit-on"):
        parse_groups(text)


def test_a_multi_fidelity_store_without_its_cheap_cells_is_diagnosed_at_its_target(caplog, tmp_path) -> None:
    """A store written before the cheap cells were recorded: every simulation at the target, said in
    the log; one that records them gives the cheapest fidelity's cell; one fidelity gives none."""
    from calibrax.diagnosis.run import _fidelities

    tiny = ShearCellSpec.preset("tiny")
    fidelities = [{"preset": "tiny", "cost": 70.0, "level": 0.0, "initial": 8},
                  {"preset": "quick", "cost": 250.0, "level": 1.0, "initial": 3}]
    with caplog.at_level("WARNING", logger="calibrax"):
        assert _fidelities({"fidelities": fidelities}, tmp_path / "old.h5") == ("quick", None)
    assert "old.h5 records no cell for its cheap fidelity tiny" in caplog.text
    target, (name, cell) = _fidelities({"fidelities": fidelities, "fidelity_cells": {"tiny": tiny.to_dict()}},
                                       tmp_path / "new.h5")
    assert (target, name, cell.particles_per_diameter) == ("quick", "tiny", tiny.particles_per_diameter)
    assert _fidelities({}, tmp_path / "one.h5") == ("", None)
