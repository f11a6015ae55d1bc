"""The FT4's density tests (issue 34, item 2): the conditioned bulk density and the compressibility
ramp, read off particles and results on known answers, from an FT4 export, through the store, and
bad input refused naming the field."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from calibrax.core.data.experiment import experiment_fingerprint, load_experiment
from calibrax.core.data.features import experiment_features, feature_stress, result_features
from calibrax.core.running.store import read_experiment_group, read_result_group, write_experiment_group, \
    write_result_group
from calibrax.core.sheartest import (SPLIT_HEIGHT_FRACTION, Provenance, ShearCellSpec, ShearTestResult, StepRecord,
                                     compressibility_percent, conditioned_bulk_density, rebase_compressibility,
                                     volume_below)
from calibrax.diagnosis.gap import diagnosis_features
from calibrax.errors import ExperimentError, SpecError
from tests.conftest import calibrax_cli, write_double_campaign, write_double_experiment

RAMP = (1000.0, 2000.0, 4000.0, 8000.0, 15000.0)


def test_a_sphere_cut_by_a_plane_counts_its_cap_below_it() -> None:
    r = np.array([1.0, 1.0, 1.0, 1.0])
    z = np.array([-5.0, 5.0, 0.0, 0.5])
    v = volume_below(z, r, 0.0)
    whole = 4.0 / 3.0 * math.pi
    assert v[0] == pytest.approx(whole) and v[1] == 0.0 and v[2] == pytest.approx(whole / 2)
    assert v[3] == pytest.approx(math.pi * 0.5**2 * (3 - 0.5) / 3)  # a cap of height 0.5


def test_the_conditioned_bulk_density_of_a_simple_cubic_packing_is_pi_over_6_of_the_solid() -> None:
    """Spheres on a simple cubic lattice of spacing 2r fill π/6 of any slab whose height is a
    whole number of layers, whatever the plane cuts: the split density is π/6 ρ_s up to the
    lattice's edge in a circle (a wide vessel makes that small)."""
    r, rho = 1.0e-3, 2500.0
    n = 120
    layers = 9
    ix, iy, iz = np.meshgrid(np.arange(-n, n), np.arange(-n, n), np.arange(layers), indexing="ij")
    x, y, z = (2 * r * ix + r).ravel(), (2 * r * iy + r).ravel(), (2 * r * iz + r).ravel()
    vessel = 2 * r * n * 0.95
    inside = np.hypot(x, y) < vessel
    density = conditioned_bulk_density(z[inside], np.full(inside.sum(), r), rho, math.pi * vessel**2)
    # the split plane lies at 3/4 of the top (18 r): 13.5 r, where the cut layer's cap fills the rest
    assert SPLIT_HEIGHT_FRACTION * 2 * r * layers == pytest.approx(13.5e-3)
    assert density == pytest.approx(math.pi / 6 * rho, rel=0.02)


def test_compressibility_is_the_volume_lost_since_the_first_stress_and_rebases_an_ft4_series() -> None:
    assert compressibility_percent(np.array([10.0, 9.9, 9.5])) == pytest.approx([0.0, 1.0, 5.0])
    # an FT4 series from the conditioned volume: 2 % at the first stress, 11.8 % at the last
    # → V/Vc = 0.98 and 0.882, so 10 % of the volume at the first stress was lost since
    assert rebase_compressibility(np.array([2.0, 11.8])) == pytest.approx([0.0, 10.0])
    assert feature_stress("compressibility_7.5kPa") == 7500.0


def _result(ramp_heights: list[float] | None, conditioned: float) -> ShearTestResult:
    spec = ShearCellSpec.preset("tiny")
    if ramp_heights is not None:
        spec = spec.replace(procedure={"compressibility_stresses": RAMP})
    rot = np.linspace(0.0, 0.3, 60)
    steps = [StepRecord("preshear", 15000.0, rot, rot, 8000 + 0 * rot, 15000 + 0 * rot, 0.01 + 0 * rot)]
    for sigma in (9000.0, 6000.0):
        steps.append(StepRecord("shear", sigma, rot, rot, sigma * 0.5 * np.sin(rot / 0.3 * 2.5), sigma + 0 * rot,
                                0.01 + 0 * rot))
    return ShearTestResult.from_steps(spec, steps, [1500.0], Provenance("hand", "-", "-", 0, 1.0, 100),
                                      conditioned_bulk_density=conditioned, compression_height=ramp_heights)


def test_a_result_gives_its_density_features_and_keeps_them_through_the_store(tmp_path) -> None:
    import h5py

    heights = [0.0100, 0.0099, 0.0098, 0.0097, 0.0096]
    result = _result(heights, 1650.0)
    f = result_features(result, 0.03)
    assert f["conditioned_bulk_density"] == 1650.0
    assert "compressibility_1kPa" not in f  # the reference: 0 by definition
    assert f["compressibility_2kPa"] == pytest.approx(1.0) and f["compressibility_15kPa"] == pytest.approx(4.0)
    assert diagnosis_features(f)["compressibility"] == pytest.approx(4.0)  # the ramp's highest stress
    assert diagnosis_features(f)["conditioned_bulk_density"] == 1650.0
    with h5py.File(tmp_path / "r.h5", "w") as h5:
        write_result_group(h5.create_group("r"), result)
    with h5py.File(tmp_path / "r.h5", "r") as h5:
        back = read_result_group(h5["r"])
    assert back.conditioned_bulk_density == 1650.0
    assert list(back.compression_stress) == list(RAMP) and back.compressibility == pytest.approx(result.compressibility)
    plain = result_features(_result(None, math.nan), 0.03)
    assert not any(k.startswith(("compressibility", "conditioned")) for k in plain)


def test_a_backend_returning_the_wrong_number_of_ramp_heights_is_a_failed_run() -> None:
    from calibrax.errors import SimulationFailed

    with pytest.raises(SimulationFailed, match="compressibility ramp has 5 stresses"):
        _result([0.01, 0.0099], 1650.0)


def _ft4_experiment(folder, ramp_rows: str, header_extra: dict | None = None):
    write_double_experiment(folder / "points.csv")
    (folder / "ramp.csv").write_text("# FT4 compressibility export\nreplicate,normal_stress_pa,compressibility_percent\n"
                                     + ramp_rows)
    header = {"name": "powder", "points": "points.csv", "compressibility": "ramp.csv",
              "conditioned_bulk_density_kg_m3": 1390.0, **(header_extra or {})}
    (folder / "exp.yaml").write_text(yaml.safe_dump(header))
    return folder / "exp.yaml"


def test_an_ft4_compressibility_export_gives_features_rebased_to_its_first_stress(tmp_path) -> None:
    import h5py

    path = _ft4_experiment(tmp_path, "1,1000,2.0\n1,15000,11.8\n2,1000,1.0\n2,15000,10.9\n")
    exp = load_experiment(path)
    feats = experiment_features(exp)
    assert feats[1]["compressibility_15kPa"] == pytest.approx(10.0)
    assert feats[2]["compressibility_15kPa"] == pytest.approx(100 * (1 - 0.891 / 0.99))
    assert feats[1]["conditioned_bulk_density"] == 1390.0
    with h5py.File(tmp_path / "e.h5", "w") as h5:
        write_experiment_group(h5.create_group("e"), exp)
    with h5py.File(tmp_path / "e.h5", "r") as h5:
        back = read_experiment_group(h5["e"])
    assert experiment_fingerprint(back) == experiment_fingerprint(exp)
    plain = load_experiment(tmp_path / "points.csv")
    assert experiment_fingerprint(plain) != experiment_fingerprint(exp)


@pytest.mark.parametrize("rows, key, message", [
    ("1,1000,2.0\n1,1000,3.0\n", "normal_stress_pa", "must increase"),
    ("1,4000,2.0\n1,2000,3.0\n", "normal_stress_pa", "4000 Pa is followed by 2000 Pa"),
    ("1,1000,2.0\n1,2000,-1\n", "compressibility_percent", r"\[0, 100\)"),
    ("9,1000,2.0\n9,2000,3.0\n", "replicate", "not in the points CSV"),
])
def test_a_bad_compressibility_export_names_the_file_and_column(tmp_path, rows, key, message) -> None:
    with pytest.raises(ExperimentError, match=message) as err:
        load_experiment(_ft4_experiment(tmp_path, rows))
    assert "ramp.csv" in err.value.key and err.value.key.endswith(key)


@pytest.mark.parametrize("ramp, message", [
    ((1000.0, 4000.0, 2000.0), "4000.0 Pa is followed by 2000.0 Pa"),
    ((1000.0,), "at least two"),
    ((1000.0, 20000.0), "must not exceed the preshear stress"),
    ((-1.0, 2000.0), "> 0"),
])
def test_a_bad_compressibility_ramp_names_the_field(ramp, message) -> None:
    with pytest.raises(SpecError, match=message) as err:
        ShearCellSpec.preset("tiny").replace(procedure={"compressibility_stresses": ramp}).validate()
    assert err.value.key == "procedure.compressibility_stresses"


def test_spec_hashes_without_a_ramp_stay_as_they_were() -> None:
    """The seed-noise caches are named by these hashes (as for material.bond_number)."""
    assert ShearCellSpec.preset("tiny").spec_hash() == ShearCellSpec.preset("tiny").replace(
        procedure={"compressibility_stresses": ()}).spec_hash()
    assert ShearCellSpec.preset("tiny").spec_hash() != ShearCellSpec.preset("tiny").replace(
        procedure={"compressibility_stresses": RAMP}).spec_hash()


def test_a_decreasing_ramp_in_a_campaign_and_in_an_experiment_exit_2_naming_them(tmp_path) -> None:
    path = write_double_campaign(tmp_path, cell={"preset": "tiny", "procedure": {
        "compressibility_stresses": [1000, 4000, 2000]}})
    proc = calibrax_cli("run", str(path), "--check")
    assert proc.returncode == 2, proc.stderr
    assert "procedure.compressibility_stresses" in proc.stderr and "increase" in proc.stderr
    folder = tmp_path / "exp"
    folder.mkdir()
    exp = _ft4_experiment(folder, "1,4000,2.0\n1,2000,3.0\n")
    path = write_double_campaign(tmp_path, experiment=str(exp))
    proc = calibrax_cli("run", str(path), "--check")
    assert proc.returncode == 2, proc.stderr
    assert "ramp.csv: normal_stress_pa" in proc.stderr and "followed by" in proc.stderr
    assert not (tmp_path / "runs").exists()
