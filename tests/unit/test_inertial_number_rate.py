"""The shear rate set by the inertial number (issue 50): a preset may state I at the preshear stress
instead of a rotation rate, the size axis of ``calibrax converge`` keeps I, and its I axis sets it."""

from __future__ import annotations

import pytest

from calibrax.core.sheartest import ShearCellSpec, inertial_number
from calibrax.core.sheartest.presets import FIDELITY_PRESETS
from calibrax.core.studies.convergence import vary, with_particles_per_diameter


def test_the_rate_for_an_inertial_number_gives_it_back() -> None:
    spec = ShearCellSpec.preset("quick")
    for target in (2e-4, 1e-3, 5e-3):
        s = spec.with_inertial_number(target)
        assert inertial_number(s, s.procedure.preshear_stress) == pytest.approx(target, rel=1e-12)
        assert inertial_number(s, 6e3) == pytest.approx(target * (15e3 / 6e3) ** 0.5, rel=1e-12)  # I ∝ 1/√σ


def test_a_preset_stated_by_inertial_number_derives_each_cells_rate(monkeypatch) -> None:
    monkeypatch.setitem(FIDELITY_PRESETS, "by_i", {**FIDELITY_PRESETS["quick"], "procedure": {
        **{k: v for k, v in FIDELITY_PRESETS["quick"]["procedure"].items() if k != "rotation_rate"},
        "inertial_number": 5e-4}})
    small, large = ShearCellSpec.preset("by_i"), ShearCellSpec.preset("by_i", radius=0.45e-3)
    for s in (small, large):
        assert inertial_number(s, 15e3) == pytest.approx(5e-4, rel=1e-12)
    assert ShearCellSpec.preset("quick").procedure.rotation_rate == 5.0  # a preset's own rate stays


def test_the_size_axis_keeps_the_inertial_number_and_the_i_axis_sets_it() -> None:
    tiny = ShearCellSpec.preset("tiny")
    i0 = inertial_number(tiny, 15e3)
    for ppd in (12.0, 20.0, 34.0):
        s = with_particles_per_diameter(tiny, ppd)
        assert s.particles_per_diameter == pytest.approx(ppd)
        assert inertial_number(s, 15e3) == pytest.approx(i0, rel=1e-12)
    assert inertial_number(vary(tiny, "inertial_number", 3e-4), 15e3) == pytest.approx(3e-4, rel=1e-12)
