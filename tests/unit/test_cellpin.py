"""A pseudo-experiment pins the cell that made it; reading one whose preset no longer resolves the
same warns, naming the field (issue 48)."""

from __future__ import annotations

import logging

import yaml

from calibrax.core.data.cellpin import cell_pin, stale_fields
from calibrax.core.data.experiment import load_experiment
from calibrax.core.sheartest import ShearCellSpec


def test_a_preset_as_it_resolves_now_is_not_stale():
    pin = cell_pin(ShearCellSpec.preset("tiny"))
    assert pin["preset"] == "tiny" and len(pin["resolved_hash"]) == 16 and pin["calibrax_version"]
    assert "numerics.seed" not in pin["resolved"] and "geometry.wall_friction" not in pin["resolved"]
    assert stale_fields(pin) == []


def test_a_field_the_maker_set_apart_from_the_preset_is_never_stale():
    spec = ShearCellSpec.preset("tiny").replace(procedure={"rotation_rate": 3.0}, geometry={"wall_friction": 0.3})
    pin = cell_pin(spec)
    assert pin["overrides"] == ["procedure.rotation_rate"]
    assert stale_fields(pin) == []


def _former_tiny() -> dict:
    """``tiny`` as it resolved when it preshore a fixed 0.12 rad."""
    pin = cell_pin(ShearCellSpec.preset("tiny"))
    pin["resolved"]["procedure.preshear_rotation"] = 0.12
    pin["resolved"]["procedure.preshear_max_rotation"] = None
    return pin


def test_a_preset_that_changed_its_procedure_is_stale_field_by_field():
    lines = stale_fields(_former_tiny())
    assert [line.split(":")[0] for line in lines] == ["cell.resolved.procedure.preshear_max_rotation",
                                                      "cell.resolved.procedure.preshear_rotation"]
    assert "0.12 when made" in lines[1] and "0.3 in 'tiny' now" in lines[1]


def _experiment(tmp_path, cell: dict, source: str = "PSEUDO-EXPERIMENT, NOT MEASURED DATA. Made by numba_dem."):
    (tmp_path / "old-points.csv").write_text("normal_stress_pa,peak_shear_stress_pa,replicate\n"
                                             "9000,5000,1\n8000,4600,1\n7000,4100,1\n6000,3700,1\n")
    header = tmp_path / "old.yaml"
    header.write_text(yaml.safe_dump({"name": "old", "source": source, "points": "old-points.csv", "cell": cell}))
    return header


def test_an_old_pseudo_experiment_whose_preset_no_longer_resolves_the_same_warns(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="calibrax"):
        exp = load_experiment(_experiment(tmp_path, _former_tiny()))
    assert any("cell.resolved.procedure.preshear_rotation" in r.getMessage() and "old.yaml" in r.getMessage()
               for r in caplog.records)
    assert len(exp.stale_cell) == 2


def test_a_header_from_before_cells_were_pinned_warns_that_it_cannot_be_checked(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="calibrax"):
        exp = load_experiment(_experiment(tmp_path, {"preset": "tiny"}))
    assert exp.stale_cell and exp.stale_cell[0].startswith("cell.resolved: missing")
    assert any("cell.resolved" in r.getMessage() for r in caplog.records)


def test_a_measured_experiment_naming_its_cell_for_the_record_is_quiet(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="calibrax"):
        exp = load_experiment(_experiment(tmp_path, {"preset": "quick"}, source="FT4, lab 2, 2026-11-01"))
    assert exp.stale_cell == () and not caplog.records


def test_the_bundled_pseudo_experiment_is_pinned_and_resolves_the_same(caplog):
    """Its header's spec hash is today's tiny's: the pin was added from that resolution."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "data" / "pseudo-numba-tiny.yaml"
    with caplog.at_level(logging.WARNING, logger="calibrax"):
        exp = load_experiment(path)
    assert exp.stale_cell == () and not caplog.records
