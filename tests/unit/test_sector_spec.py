"""The periodic sector's spec (``geometry.sector``): what it derives (the core, the particles, the
area the bed fills), the values it refuses before anything runs (exit 2 naming the field), and the
backends without rotational periodicity (LIGGGHTS, YADE) refusing it, and branched steps."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from calibrax.core.sheartest import ShearCellSpec
from calibrax.core.sheartest.sector import SECTOR_MARGIN_FRACTION, core_radius
from calibrax.errors import SpecError
from tests.conftest import write_double_campaign
from tests.unit.test_bad_inputs import refused

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_the_core_follows_dem_engines_rule_and_the_full_cell_has_none() -> None:
    """r_core + r_max = (r_max + δ)/sin(π/k), δ = 0.3 r_min; the sector holds its share of the
    particles outside the core, and the full cell is the former spec to the last bit."""
    tiny = ShearCellSpec.preset("tiny")
    quarter = tiny.replace(geometry={"sector": 4})
    r = tiny.radius
    assert quarter.core_radius + r == pytest.approx((r + SECTOR_MARGIN_FRACTION * r) / math.sin(math.pi / 4))
    assert tiny.core_radius == 0.0 and core_radius(1, r, r) == 0.0
    rc = tiny.geometry.vessel_diameter / 2
    assert quarter.bed_cross_section == pytest.approx(math.pi * (rc**2 - quarter.core_radius**2) / 4)
    assert tiny.bed_cross_section == math.pi * rc**2
    assert quarter.particle_count == round(tiny.particle_count * quarter.bed_cross_section / tiny.bed_cross_section)
    assert tiny.spec_hash() == "e63518d9b579362c"  # the full cell's hash from before the field existed
    assert quarter.spec_hash() != tiny.spec_hash()
    assert "1/4 sector" in quarter.cell_words() and "sector" not in tiny.cell_words()


@pytest.mark.parametrize("sector, words", [
    (0, "must be an integer ≥ 1"), (-2, "must be an integer ≥ 1"), (2.5, "must be an integer"),
    (3, "must divide geometry.blade_count (8)"), (8, "wider than the hub"),
])
def test_a_bad_sector_is_refused_naming_the_field(sector, words) -> None:
    with pytest.raises(SpecError, match="geometry.sector") as err:
        ShearCellSpec.preset("tiny").replace(geometry={"sector": sector}).validate()
    assert words in str(err.value)


@pytest.mark.parametrize("geometry, words", [
    ({"sector": 4, "core_radius": 0.1e-3}, "needs a core of at least 0.755 mm"),
    ({"core_radius": 2.0e-3}, "must be smaller than the hub"),
    ({"core_radius": -1.0e-3}, "must be > 0"),
])
def test_a_bad_core_radius_is_refused_naming_the_field(geometry, words) -> None:
    with pytest.raises(SpecError, match="geometry.core_radius") as err:
        ShearCellSpec.preset("tiny").replace(geometry=geometry).validate()
    assert words in str(err.value)


def test_a_full_cell_may_carry_a_sectors_core() -> None:
    """The core alone, to measure what it changes: the full cell with the core of a 1/4 sector."""
    tiny = ShearCellSpec.preset("tiny")
    cored = tiny.replace(geometry={"core_radius": tiny.replace(geometry={"sector": 4}).core_radius}).validate()
    assert cored.core_radius == pytest.approx(0.755e-3, abs=1e-6)
    assert cored.particle_count < tiny.particle_count and "a frictionless core of 0.75 mm" in cored.cell_words()


def test_a_sector_too_narrow_for_its_core_names_the_sectors_allowed() -> None:
    with pytest.raises(SpecError) as err:
        ShearCellSpec.preset("tiny").replace(geometry={"sector": 8}).validate()
    assert "allowed: [1, 2, 4]" in str(err.value)


@pytest.mark.parametrize("simulator", ["numba_dem", "liggghts", "yade"])
def test_run_check_refuses_a_bad_sector_with_exit_2(tmp_path, capsys, simulator) -> None:
    campaign = write_double_campaign(tmp_path, simulator=simulator,
                                     cell={"preset": "tiny", "geometry": {"sector": 3}})
    message = refused(capsys, "run", str(campaign), "--check")
    assert "cell.geometry.sector" in message and "must divide" in message
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("simulator", ["liggghts", "yade"])
@pytest.mark.parametrize("cell, field, capability", [
    ({"geometry": {"sector": 2}}, "cell.geometry.sector", "sector"),
    ({"procedure": {"branches": True}}, "cell.procedure.branches", "branched_steps"),
])
def test_liggghts_and_yade_refuse_a_sector_and_branches(tmp_path, capsys, simulator, cell, field, capability) -> None:
    """LIGGGHTS and YADE stay the full cell's sequential cross-check: a sector or branched steps
    exit 2 naming the field."""
    campaign = write_double_campaign(tmp_path, simulator=simulator, cell={"preset": "tiny", **cell})
    message = refused(capsys, "run", str(campaign), "--check")
    assert field in message and f"{simulator} cannot model ['{capability}']" in message


def test_numba_dem_takes_a_sector(tmp_path, capsys) -> None:
    campaign = write_double_campaign(tmp_path, simulator="numba_dem",
                                     cell={"preset": "tiny", "geometry": {"sector": 4}})
    from calibrax.cli import main

    assert main(["run", str(campaign), "--check"]) == 0
    out = capsys.readouterr().out
    assert "a 1/4 sector (frictionless core 0.75 mm; 4.5 diameters wide at ⅔ R_head)" in out


def test_a_crosscheck_runs_the_full_cell_where_a_backend_has_no_sector(tmp_path) -> None:
    """numba_dem runs the sector, LIGGGHTS and YADE the full cell it stands for: the cross-check is
    how a sector is checked against the full cell."""
    from calibrax.core.config import load_config
    from calibrax.core.studies.crosscheck import crosscheck_cases

    path = write_double_campaign(tmp_path, simulator="numba_dem", cell={"preset": "tiny", "geometry": {"sector": 4}})
    cases = crosscheck_cases(load_config(path), ["numba_dem", "liggghts", "yade"], 2, [])
    sectors = {c.backend: c.spec.geometry.sector for c in cases}
    assert sectors == {"numba_dem": 4, "liggghts": 1, "yade": 1}
    assert len({c.spec.replace(geometry={"sector": 1}).spec_hash() for c in cases}) == 1


def test_a_fidelity_preset_may_state_a_sector(monkeypatch) -> None:
    """A preset's ``sector`` reaches the geometry; the presets without one stay full cells, to the hash."""
    from calibrax.core.sheartest import presets

    before = ShearCellSpec.preset("paper").spec_hash()
    monkeypatch.setitem(presets.FIDELITY_PRESETS, "paper_sector", {**presets.FIDELITY_PRESETS["paper"], "sector": 9})
    spec = ShearCellSpec.preset("paper_sector").validate()
    assert spec.geometry.sector == 9
    assert spec.particle_count < ShearCellSpec.preset("paper").particle_count / 8
    assert ShearCellSpec.preset("paper").geometry.sector == 1
    assert ShearCellSpec.preset("paper").spec_hash() == before


def test_the_converged_preset_is_the_measured_candidate() -> None:
    """``converged`` is the cell docs/explanation/sector.md measured: examples/converge-sector.yaml
    taken to 46 per diameter the paper's way (``calibrax converge``'s size axis: the vessel grows,
    the particles and I stay), the paper's cell as a 1/9 sector at quick's inertial number,
    branched, with the noise correction. Only the name and the last bits of the scaled lengths
    differ."""
    from calibrax.core.config import load_config
    from calibrax.core.sheartest.physics import inertial_number
    from calibrax.core.studies.convergence import with_particles_per_diameter

    converged = ShearCellSpec.preset("converged").validate()
    quick = ShearCellSpec.preset("quick")
    assert converged.geometry.sector == 9 and converged.procedure.branches
    assert converged.particle_count < ShearCellSpec.preset("paper").particle_count / 3
    assert inertial_number(converged, 15e3) == pytest.approx(inertial_number(quick, 15e3), rel=1e-12)
    candidate = with_particles_per_diameter(load_config(EXAMPLES / "converge-sector.yaml").spec, 46)
    lengths = ("vessel_diameter", "fill_height", "head_radius", "hub_radius")
    for name in lengths:
        assert getattr(candidate.geometry, name) == pytest.approx(getattr(converged.geometry, name), rel=1e-12), name
    assert candidate.procedure.rotation_rate == pytest.approx(converged.procedure.rotation_rate, rel=1e-12)
    rounded = candidate.replace(name="converged", numerics={"threads": converged.numerics.threads},
                                geometry={name: getattr(converged.geometry, name) for name in lengths},
                                procedure={"rotation_rate": converged.procedure.rotation_rate})
    assert rounded == converged