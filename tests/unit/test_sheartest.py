"""ShearCellSpec: the paper's eq. (1), presets, validation of bad specs, peak finding."""

from __future__ import annotations

import numpy as np
import pytest

from calibrax import ShearCellSpec, critical_time_step, find_peak, shear_stress_from_torque
from calibrax.errors import SpecError


def test_critical_time_step_of_table1_at_15kpa_is_the_papers_5_9_us():
    spec = ShearCellSpec.preset("paper")
    # σ0 = 15 kPa (the preshear stress), Table 1 material: E = 25 GPa, ν = 0.25, ρ = 3000, R = 0.9 mm
    assert spec.numerics.stress_for_dt is None and spec.procedure.preshear_stress == 15e3
    assert spec.critical_time_step == pytest.approx(5.89e-6, rel=2e-3)
    assert critical_time_step(0.9e-3, 3000.0, 25e9 / (1 - 0.25**2), 15e3) == pytest.approx(5.894868e-6, rel=1e-6)
    assert spec.time_step == pytest.approx(0.05 * spec.critical_time_step)


def test_paper_preset_has_the_papers_31k_particles_at_34_per_diameter():
    spec = ShearCellSpec.preset("paper")
    assert spec.particles_per_diameter == pytest.approx(34.0)
    assert 30_000 < spec.particle_count < 32_500  # the paper: 31k particles


def test_procedures_paper_and_astm():
    astm = ShearCellSpec.preset("quick", "astm_d7891")
    assert astm.procedure.preshear_stress == 9e3 and astm.procedure.shear_stresses == (7e3, 6e3, 5e3, 4e3, 3e3)
    assert ShearCellSpec.preset("quick").procedure.shear_stresses == (9e3, 8e3, 7e3, 6e3)
    low = ShearCellSpec.preset("tiny", "ft4_3kpa").validate()
    assert low.procedure.preshear_stress == 3e3 and low.procedure.shear_stresses == (2e3, 1.75e3, 1.5e3, 1.25e3, 1e3)


def test_consolidation_limit_follows_the_procedure():
    """Six preshear rotations' time, not a fixed 0.12 s: the paper's 0.5 rad/s needs 0.6 s for its
    first rotation alone (issue 22)."""
    times = {name: (ShearCellSpec.preset(name).procedure.consolidation_min_time,
                    ShearCellSpec.preset(name).procedure.consolidation_time_limit)
             for name in ("tiny", "quick", "paper")}
    assert times["paper"] == pytest.approx((0.6, 3.6))
    assert times["quick"] == pytest.approx((0.06, 0.36))  # a preshear of at least 0.3 rad at 5 rad/s
    assert times["tiny"] == pytest.approx((0.05, 0.30))
    fast = ShearCellSpec.preset("tiny").replace(procedure={"rotation_rate": 100.0}).procedure
    assert fast.consolidation_min_time == 0.01 and fast.consolidation_time_limit == pytest.approx(0.06)


def test_wall_rolling_friction_defaults_to_every_backends_former_rule():
    """None: the particles' μr against a wall with friction, 0 against a frictionless one; a value
    set is taken as it is."""
    tiny = ShearCellSpec.preset("tiny")
    mu_r = tiny.material.rolling_friction
    assert tiny.effective_wall_rolling_friction() == 0.0
    assert tiny.replace(geometry={"wall_friction": 0.3}).effective_wall_rolling_friction() == mu_r
    assert tiny.replace(geometry={"wall_friction": 0.3, "wall_rolling_friction": 0.0}).effective_wall_rolling_friction() == 0.0
    assert tiny.replace(geometry={"wall_rolling_friction": 0.2}).effective_wall_rolling_friction() == 0.2


def test_spec_roundtrips_through_dict_and_hash_is_stable():
    spec = ShearCellSpec.preset("tiny", material={"sliding_friction": 0.3})
    again = ShearCellSpec.from_dict(spec.to_dict())
    assert again == spec and again.spec_hash() == spec.spec_hash()
    assert spec.replace(numerics={"seed": 1}).spec_hash() != spec.spec_hash()


@pytest.mark.parametrize("changes, key", [
    ({"radius": -1e-3}, "radius"),
    ({"material": {"poisson_ratio": 0.5}}, "material.poisson_ratio"),
    ({"numerics": {"dt_fraction": 1.5}}, "numerics.dt_fraction"),
    ({"procedure": {"preshear_stress": 0.0}}, "procedure.preshear_stress"),
    ({"procedure": {"shear_stresses": (9e3, -1.0)}}, "procedure.shear_stresses"),
    ({"geometry": {"blade_count": 400}}, "geometry.blade_count"),
    ({"geometry": {"vessel_diameter": 4e-3, "head_radius": 1.9e-3, "hub_radius": 0.2e-3,
                   "fill_height": 4e-3}}, "geometry.vessel_diameter"),
    ({"material": {"sliding_friction": 0.0}, "geometry": {"base_friction": 0.0, "base_ribs": 0}},
     "geometry.base_friction"),
    ({"material": {"youngs_modulus": float("nan")}}, "material.youngs_modulus"),
    ({"geometry": {"wall_rolling_friction": -0.1}}, "geometry.wall_rolling_friction"),
    ({"geometry": {"wall_rolling_friction": "none"}}, "geometry.wall_rolling_friction"),
    ({"procedure": {"steady_tolerance": -0.01}}, "procedure.steady_tolerance"),
    ({"procedure": {"steady_window": 0.0}}, "procedure.steady_window"),
    ({"procedure": {"preshear_rotation": 0.5, "preshear_max_rotation": 0.4}}, "procedure.preshear_max_rotation"),
    ({"procedure": {"preshear_rotation": 0.1, "preshear_max_rotation": 0.3, "steady_window": 0.2}},
     "procedure.steady_window"),
])
def test_bad_specs_are_refused_with_the_field_named(changes, key):
    with pytest.raises(SpecError) as err:
        ShearCellSpec.preset("tiny").replace(**changes).validate()
    assert err.value.key == key


def test_find_peak_is_the_max_of_a_running_mean():
    rot = np.linspace(0.0, 0.2, 401)
    tau = 1000.0 * np.exp(-((rot - 0.05) / 0.02) ** 2)
    rng = np.random.default_rng(0)
    noisy = tau + rng.normal(0.0, 50.0, rot.size)
    peak, i, where = find_peak(rot, noisy, window=0.01)
    assert abs(rot[i] - 0.05) < 0.01 and 0.9 * 1000 < peak < 1000
    assert where == pytest.approx(0.25, abs=0.05)
    # a monotonic curve peaks at the window's end
    assert find_peak(rot, rot, 0.01)[2] > 0.95


def test_shear_stress_from_torque():
    assert shear_stress_from_torque(2.0, 0.5) == pytest.approx(3 * 2.0 / (2 * np.pi * 0.125))


def _shear_result_at(spec, friction: float):
    """One preshear and one shear step at 9 kPa whose τ is ``friction`` · σ throughout (hand-made
    records, the real result type)."""
    from calibrax.core.sheartest import Provenance, ShearTestResult, StepRecord

    rot = np.linspace(0.0, 0.12, 100)
    full = lambda v: np.full(rot.size, v)  # noqa: E731
    pre = StepRecord("preshear", 15000.0, rot / 5.0, rot, full(7000.0), full(15000.0), full(0.02))
    shear = StepRecord("shear", 9000.0, rot / 5.0, rot, full(friction * 9000.0), full(9000.0), full(0.02))
    return ShearTestResult.from_steps(spec, [pre, shear], [1500.0], Provenance("hand", "-", "-", 0, 1.0, 100))


def test_base_capacity_is_the_flat_bases_coulomb_limit_under_uniform_pressure():
    from calibrax.core.sheartest import base_shear_capacity

    spec = ShearCellSpec.preset("quick", geometry={"base_ribs": 0})
    g = spec.geometry
    k = g.vessel_diameter / 2 / g.head_radius
    # μ_b [σ R_v/R_h + ρ g H (R_v/R_h)³] with μ_b = the particles' 0.5
    assert base_shear_capacity(spec, 9000.0, 1500.0, 0.02) == pytest.approx(0.5 * (9000.0 * k + 1500.0 * 9.81 * 0.02 * k**3))
    assert base_shear_capacity(spec.replace(geometry={"base_friction": 1.0}), 9000.0, 1500.0, 0.02) == pytest.approx(
        2 * base_shear_capacity(spec, 9000.0, 1500.0, 0.02))
    # ribs or a lateral wall with friction also hold the bed: the bound does not apply
    assert np.isnan(base_shear_capacity(spec.replace(geometry={"base_ribs": 12}), 9000.0, 1500.0, 0.02))
    assert np.isnan(base_shear_capacity(spec.replace(geometry={"wall_friction": 0.3}), 9000.0, 1500.0, 0.02))


def test_a_bed_sliding_on_its_base_is_flagged_and_one_held_by_it_is_not():
    from calibrax.core.sheartest import steady_base_load

    spec = ShearCellSpec.preset("quick", geometry={"base_ribs": 0})  # flat, μ_b = 0.5: holds τ ≤ 0.54 σ at 9 kPa
    sliding = _shear_result_at(spec, 0.53)
    assert steady_base_load(spec, sliding.steps, sliding.bulk_density) == pytest.approx(0.98, abs=0.01)
    assert any("slid on the base" in w for w in sliding.warnings)
    held = _shear_result_at(spec, 0.40)
    assert not any("slid on the base" in w for w in held.warnings)
    ribbed = spec.replace(geometry={"base_ribs": 12})
    assert not any("slid on the base" in w for w in _shear_result_at(ribbed, 0.53).warnings)


def test_with_base_ribs_no_particle_starts_inside_a_rib():
    from calibrax.core.sheartest.packing import initial_packing

    spec = ShearCellSpec.preset("tiny")
    assert spec.geometry.base_ribs == 8  # the default base
    pack = initial_packing(spec)
    assert np.all(pack.positions[:, 2] - pack.radii >= spec.geometry.rib_height)
    flat = initial_packing(ShearCellSpec.preset("tiny", geometry={"base_ribs": 0}))
    np.testing.assert_allclose(pack.positions[:, 2] - flat.positions[:, 2], spec.geometry.rib_height)


def test_every_preset_holds_the_bed_with_one_diameter_ribs_by_default():
    for name in ("tiny", "quick", "paper"):
        spec = ShearCellSpec.preset(name)
        assert spec.geometry.base_ribs == spec.geometry.blade_count
        assert spec.geometry.rib_height == pytest.approx(2 * spec.radius)
        assert spec.geometry.wall_friction == 0.0  # the paper's frictionless lateral wall stays


def _with_spin(result, spin_fraction: float):
    """The same hand-made result with its bottom layer turning at ``spin_fraction`` of the head's rate."""
    import dataclasses

    from calibrax.core.sheartest import ShearTestResult

    steps = [dataclasses.replace(s, base_spin=np.full(s.time.size, spin_fraction * 5.0)) for s in result.steps]
    return ShearTestResult.from_steps(ShearCellSpec.preset("quick"), steps, [1500.0], result.provenance)


def test_slip_is_measured_from_the_bottom_layers_spin_whatever_the_base():
    # a ribbed base (the bound does not apply) whose bottom layer turns with the head is flagged,
    # one whose bottom layer stands still is not, and the measured slip is the spin over the head's rate
    ribbed = ShearCellSpec.preset("quick")
    turning = _with_spin(_shear_result_at(ribbed, 0.7), 0.8)
    assert turning.base_slip == pytest.approx([0.8])
    assert any("slid on the base" in w for w in turning.warnings)
    still = _with_spin(_shear_result_at(ribbed, 0.7), 0.02)
    assert not any("slid on the base" in w for w in still.warnings)


def test_layer_spin_is_the_mean_angular_velocity_of_the_layer():
    from calibrax.core.sheartest import base_layer_bounds, layer_spin

    rng = np.random.default_rng(1)
    x = rng.uniform(-0.01, 0.01, (200, 3))
    x[:, 2] = rng.uniform(0.0, 0.01, 200)
    omega = 3.0
    v = np.stack([-omega * x[:, 1], omega * x[:, 0], np.zeros(200)], axis=1)  # rigid rotation
    assert layer_spin(x, v, 0.0, 0.002) == pytest.approx(omega)
    assert np.isnan(layer_spin(x, v, 0.02, 0.03))
    spec = ShearCellSpec.preset("tiny")
    assert base_layer_bounds(spec) == pytest.approx((spec.geometry.rib_height, spec.geometry.rib_height + 2 * spec.radius))


def test_a_locus_whose_peaks_fall_with_sigma_is_flagged():
    from calibrax.core.sheartest import locus_warning

    sigma = np.array([9000.0, 8000.0, 7000.0, 6000.0])
    assert locus_warning(sigma, 1000.0 + 0.7 * sigma) is None  # cohesive-frictional: nothing to say
    bumpy = locus_warning(sigma, np.array([6273.0, 3165.0, 4842.0, 5625.0]))  # make run's best point
    assert bumpy.startswith("the peaks do not rise with σ (5625 Pa at 6 kPa, 4842 Pa at 7 kPa")
    assert "AIF = " in bumpy and "seeds_per_point" in bumpy
    assert "the peaks do not rise" in locus_warning(sigma, 9000.0 - 0.3 * sigma)  # falling: AIF < 0 too
    assert locus_warning(sigma, np.array([5000.0, np.nan, 4000.0, 3500.0])) is None  # NaN: another check's job
    # and a result carries it
    from calibrax.core.sheartest import Provenance, ShearTestResult, StepRecord

    rot = np.linspace(0.0, 0.12, 100)
    full = lambda v: np.full(rot.size, v)  # noqa: E731
    steps = []
    for target, tau in zip(sigma, (4000.0, 5000.0, 6000.0, 7000.0)):  # strongest at the lowest σ
        steps.append(StepRecord("preshear", 15000.0, rot / 5.0, rot, full(9000.0), full(15000.0), full(0.02)))
        steps.append(StepRecord("shear", target, rot / 5.0, rot, full(tau), full(target), full(0.02)))
    res = ShearTestResult.from_steps(ShearCellSpec.preset("tiny"), steps, [1500.0] * 4,
                                     Provenance("hand", "-", "-", 0, 1.0, 100))
    assert any(w.startswith("the peaks do not rise with σ") for w in res.warnings), res.warnings


@pytest.mark.parametrize("preset, gap_d, wall, warned", [
    ("converged", 0.92, 0.3, True),   # 0.02 D, the preset's gap before 2026-12-07: a particle wedges (measured)
    ("paper", 0.68, 0.1, True),       # 0.02 D at 34/d: still between a radius and a diameter
    ("converged", 0.92, 0.0, False),  # a frictionless wall holds no wedge
    ("converged", None, 0.3, False),  # the preset's own gap, 0.24 d
    ("paper", None, 0.3, False),      # 0.24 d
    ("quick", None, 0.3, False),      # 0.24 d: no particle's centre passes the rim
    ("tiny", None, 0.45, False),      # 0.18 d
])
def test_a_frictional_wall_beside_a_rim_gap_that_wedges_particles_is_flagged(preset, gap_d, wall, warned):
    """docs/explanation/sector.md, "A frictional wall and the rim gap"."""
    from calibrax.core.sheartest import rim_gap_warning

    spec = ShearCellSpec.preset(preset).replace(geometry={"wall_friction": wall})
    if gap_d is not None:
        spec = spec.replace(geometry={"head_radius": spec.geometry.vessel_diameter / 2.0 - gap_d * 2.0 * spec.radius})
    warning = rim_gap_warning(spec)
    assert (warning is not None) == warned, warning
    if warned:
        assert f"the head's rim is {gap_d:.2f} particle diameters from a frictional wall" in warning
        assert "geometry.head_radius" in warning
        # the remedy it names clears it: the head at the radius it asks for
        radius = float(warning.split("geometry.head_radius ≥ ")[1].split(" mm")[0]) * 1e-3
        assert radius == pytest.approx(spec.geometry.vessel_diameter / 2.0 - spec.radius, abs=1e-6)
        assert rim_gap_warning(spec.replace(geometry={"head_radius": radius})) is None


def test_the_presets_rim_gap_is_kept_in_particle_diameters_along_size():
    """``paper`` and ``converged`` state their gap in d (0.24, under one radius); the size axis of
    ``calibrax converge`` keeps a cell's gap in metres and its inertial number, where scaling the
    gap with D took 0.24 d at 12/d to 0.92 d at 46/d."""
    from calibrax.core.sheartest.physics import inertial_number
    from calibrax.core.studies.convergence import with_particles_per_diameter

    def gap_d(spec):
        return (spec.geometry.vessel_diameter / 2.0 - spec.geometry.head_radius) / (2.0 * spec.radius)

    for name in ("paper", "converged"):
        assert gap_d(ShearCellSpec.preset(name)) == pytest.approx(0.24, rel=1e-9), name
    quick = ShearCellSpec.preset("quick")
    for ppd in (16.0, 46.0, 60.0):
        grown = with_particles_per_diameter(quick, ppd)
        assert grown.geometry.vessel_diameter == pytest.approx(ppd * 2.0 * quick.radius, rel=1e-12)
        assert gap_d(grown) == pytest.approx(gap_d(quick), rel=1e-9)
        assert inertial_number(grown, 15e3) == pytest.approx(inertial_number(quick, 15e3), rel=1e-12)


def test_a_result_carries_the_rim_gap_warning():
    from calibrax.core.sheartest import Provenance, ShearTestResult, StepRecord

    rot = np.linspace(0.0, 0.3, 100)
    full = lambda v: np.full(rot.size, v)  # noqa: E731
    steps = []
    for target in (9000.0, 8000.0, 7000.0, 6000.0):
        steps.append(StepRecord("preshear", 15000.0, rot / 5.0, rot, full(9000.0), full(15000.0), full(0.02)))
        steps.append(StepRecord("shear", target, rot / 5.0, rot, full(0.7 * target), full(target), full(0.02)))
    converged = ShearCellSpec.preset("converged")
    wedging_head = converged.geometry.vessel_diameter * 0.48  # the gap of 0.02 D, 0.92 d
    spec = converged.replace(geometry={"wall_friction": 0.3, "head_radius": wedging_head})
    res = ShearTestResult.from_steps(spec, steps, [1500.0] * 4, Provenance("hand", "-", "-", 0, 1.0, 100))
    assert any(w.startswith("the head's rim is 0.92 particle diameters") for w in res.warnings), res.warnings


def test_preshear_drift_compares_the_last_two_windows():
    from calibrax.core.sheartest import preshear_drift, steady_window_samples

    rot = np.arange(1, 101) * 0.004  # 100 samples of 0.004 rad: a window of 0.1 rad is 25 samples
    assert steady_window_samples(rot, 0.1) == 25
    sigma = np.full(100, 15000.0)
    flat = np.full(100, 9000.0)
    assert preshear_drift(rot, flat, sigma, 0.1) == 0.0
    ramp = 9000.0 * (1.0 + 0.002 * np.arange(100))  # τ still rising: the last 25 against the 25 before
    expected = (ramp[-25:].mean() - ramp[-50:-25].mean()) / ramp[-25:].mean()
    assert preshear_drift(rot, ramp, sigma, 0.1) == pytest.approx(expected)
    assert np.isnan(preshear_drift(rot[:40], ramp[:40], sigma[:40], 0.1))  # shorter than two windows


def test_steady_schedule_checks_after_the_minimum_and_two_windows_until_the_cap():
    from calibrax.core.sheartest import steady_schedule

    proc = ShearCellSpec.preset("tiny").replace(procedure={
        "preshear_rotation": 0.2, "preshear_max_rotation": 0.6, "steady_window": 0.1}).procedure
    assert steady_schedule(proc, 0.01) == (20, 60, 10, 2)
    short = ShearCellSpec.preset("tiny").replace(procedure={
        "preshear_rotation": 0.05, "preshear_max_rotation": 0.6, "steady_window": 0.1}).procedure
    assert steady_schedule(short, 0.01)[0] == 20  # two windows before the first check


def _preshear_result(preshear_tau, cap):
    """A result from hand-made steps (no engine): four preshears with τ series ``preshear_tau``
    (each shape (n,), Pa) at σ = 15 kPa, then flat shear steps."""
    from calibrax.core.sheartest import Provenance, ShearTestResult, StepRecord

    steps = []
    for tau, target in zip(preshear_tau, (9000.0, 8000.0, 7000.0, 6000.0)):
        rot = np.arange(1, tau.size + 1) * 0.004
        steps.append(StepRecord("preshear", 15000.0, rot, rot, tau, np.full(tau.size, 15000.0), np.zeros(tau.size)))
        srot = np.arange(1, 51) * 0.004
        steps.append(StepRecord("shear", target, srot, srot, 0.7 * target + 10.0 * np.arange(50),
                                np.full(50, target), np.zeros(50)))
    spec = ShearCellSpec.preset("tiny").replace(procedure={
        "preshear_rotation": 0.2, "preshear_max_rotation": cap, "steady_window": 0.1, "steady_tolerance": 0.05})
    return ShearTestResult.from_steps(spec, steps, [1500.0] * 4, Provenance("hand", "-", "-", 0, 1.0, 100))


def test_a_preshear_that_ended_before_steady_state_is_warned_about():
    """The criterion's record: each preshear's rotation and drift are in the result, and one whose
    τ/σ still drifted by more than the tolerance when it ended (at its cap) makes a warning naming
    it; steady ones make none."""
    steady = [np.full(60, 9000.0)] * 4
    ok = _preshear_result(steady, 0.6)
    assert not any("steady" in w for w in ok.warnings), ok.warnings
    np.testing.assert_allclose(ok.preshear_rotation, 0.24)
    np.testing.assert_allclose(ok.preshear_drift, 0.0)
    rising = 9000.0 * (1.0 + 0.01 * np.arange(150))  # τ/σ still climbing by 25 % a window at the cap
    bad = _preshear_result([steady[0], rising, steady[0], steady[0]], 0.6)
    assert bad.preshear_drift[1] > 0.05 and bad.preshear_rotation[1] == pytest.approx(0.6)
    warned = [w for w in bad.warnings if "ended before τ/σ was steady" in w]
    assert len(warned) == 1 and warned[0].startswith("1 of 4 preshears") and "preshear 1: 0.60 rad" in warned[0]
    assert "procedure.preshear_max_rotation" in warned[0]
    # a fixed-length preshear (no cap) states its drift but is not held to the criterion
    fixed = _preshear_result([steady[0], rising, steady[0], steady[0]], None)
    assert fixed.preshear_drift[1] > 0.05 and not any("steady" in w for w in fixed.warnings)


def test_a_preshears_steady_value_averages_all_of_it_after_the_first_window():
    """A preshear that runs until steady is averaged from the end of its first steady-state window
    on (its reloading transient left out, all its steady rotation in); a fixed one over its last
    40 %; a capped one too short for that falls back to the last 40 %."""
    from calibrax.core.sheartest import preshear_steady_part

    capped = ShearCellSpec.preset("tiny").procedure  # steady_window 0.1 rad, capped
    rot = (np.arange(100) + 0.5) * 0.004  # 0.4 rad in 100 samples
    assert preshear_steady_part(rot, capped) == slice(25, None)  # from 0.1 rad on
    fixed = ShearCellSpec.preset("tiny").replace(procedure={"preshear_max_rotation": None}).procedure
    assert preshear_steady_part(rot, fixed) == slice(60, None)
    assert preshear_steady_part(rot[:30], capped) == slice(18, None)  # 0.12 rad: the last 40 %
    # the result's preshear τ: a 0.1 rad transient at 12 kPa, then 9 kPa, read as 9 kPa
    tau = np.where(np.arange(1, 101) * 0.004 < 0.099, 12000.0, 9000.0)
    result = _preshear_result([tau] * 4, 0.6)
    np.testing.assert_allclose(result.preshear_shear_stress, 9000.0)


def test_a_results_cpu_is_the_engines_own_count_where_it_keeps_one_else_wall_time_by_threads() -> None:
    """numba_dem counts every thread's process time by stage; a subprocess engine is priced at
    wall × threads (a diagnosis's and a benchmark's cost are CPU, not wall time)."""
    from calibrax.core.sheartest.result import Provenance

    counted = Provenance("numba_dem", "0.1", "h", 0, wall_time=600.0, particle_count=10, threads=2,
                         extra={"stage_cpu": {"pour": 100.0, "shear": 1000.0}})
    assert counted.cpu_seconds == pytest.approx(1100.0)
    subprocess_engine = Provenance("liggghts", "3.8", "h", 0, wall_time=600.0, particle_count=10, threads=2)
    assert subprocess_engine.cpu_seconds == pytest.approx(1200.0)
    # a stored simulation counts the same (a resumed campaign's progress), and a failure, with no
    # provenance, at wall × the campaign's threads
    from dataclasses import asdict

    from calibrax.core.search.records import SimulationRecord, Status

    for prov in (counted, subprocess_engine):
        stored = SimulationRecord(0, 0, Status.DONE, 600.0, provenance=asdict(prov))
        assert stored.cpu_seconds(threads=4) == pytest.approx(prov.cpu_seconds)
    assert SimulationRecord(0, 0, Status.FAILED, 600.0).cpu_seconds(threads=4) == pytest.approx(2400.0)
