"""Bad campaign files: each gives a ConfigError naming the key and what is allowed, exit code 2,
and nothing written."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
import yaml

from calibrax.cli import main
from tests.conftest import calibrax_cli, write_double_campaign

CASES = [
    # (change to the campaign mapping, text the message must contain)
    (lambda c: c.update(colour="red"), "colour: unknown key; allowed:"),
    (lambda c: c.pop("simulator"), "simulator: is required"),
    (lambda c: c.update(simulator="fortran_dem"), "simulator: unknown simulator 'fortran_dem'; known: ["),
    (lambda c: c.update(acquisition={"name": "ucb", "q": 2}), "acquisition: unknown acquisition 'ucb'; known: ['mfei', 'mfkg', 'qei'"),
    # double_terms: the third-party-style test plugin (tests/doubles/thirdparty_plugin.py)
    (lambda c: c.update(metric="rmse"), "metric: unknown metric 'rmse'; known: ['c_aif', 'double_terms', 'robust']"),
    (lambda c: c["parameters"]["sliding_friction"].update(low=0.9, high=0.1), "parameters.sliding_friction: low must be < high"),
    (lambda c: c["parameters"]["youngs_modulus"].update(low="5 GPa"), "parameters.youngs_modulus.low: must be a number"),
    (lambda c: c.update(budget={"initial": 1, "iterations": 3}), "budget.initial: must be an integer ≥ 2"),
    (lambda c: c.update(budget={"initial": 4, "iterations": "many"}), "budget.iterations: must be an integer"),
    (lambda c: c.update(experiment="missing.csv"), "missing.csv: file not found"),
    (lambda c: c.update(material={"poisson_ratio": 0.7}), "material.poisson_ratio: must lie in [0, 0.5)"),
    (lambda c: c.update(material={"restitution": float("nan")}), "material.restitution: must be a finite number"),
    (lambda c: c.update(cell={"preset": "huge"}), "cell.preset: unknown preset 'huge'; allowed: ['converged', 'paper', 'quick', 'tiny']"),
    (lambda c: c.update(cell={"preset": "tiny", "numerics": {"dt_fraction": 2.0}}), "cell.numerics.dt_fraction: must lie in (0, 1]"),
    (lambda c: c.update(cell={"preset": "tiny", "geometry": {"wheels": 3}}), "cell.geometry.wheels: unknown key"),
    (lambda c: c.update(executor={"name": "local", "workers": 0}), "executor.workers: must be an integer ≥ 1"),
    (lambda c: c.update(acquisition={"name": "qei", "q": 0}), "acquisition.q: must be an integer ≥ 1"),
    (lambda c: c.update(store="runs/out.txt"), "store: must name an HDF5 file"),
    (lambda c: c.update(metric={"name": "c_aif", "scale_aif_deg": -2}), "metric.scale_aif_deg: must be > 0, got -2"),
    (lambda c: c.update(cell={"procedure": "iso_9000"}), "cell.procedure: unknown procedure 'iso_9000'"),
    (lambda c: c.update(description=["batch 3", "B4C"]), "description: must be text, got list"),
    # multi-fidelity campaigns (fidelities: cheapest first, the target last)
    (lambda c: c.update(fidelities=["tiny"]), "fidelities: must be a list of two or more fidelity presets"),
    (lambda c: c.update(fidelities=["tiny", "huge"]), "fidelities[1]: unknown preset 'huge'; allowed: ['converged', 'paper', 'quick', 'tiny']"),
    (lambda c: c.update(fidelities=["quick", "tiny"]), "fidelities[1]: costs 70 CPU-s per simulation, no more than fidelities[0]"),
    (lambda c: c.update(fidelities=["tiny", "tiny"]), "fidelities[1]: preset 'tiny' is listed twice"),
    (lambda c: c.update(fidelities=["tiny", {"preset": "quick", "cost": -1}]), "fidelities[1].cost: must be a finite number > 0"),
    (lambda c: c.update(fidelities=["tiny", {"preset": "quick", "colour": 1}]), "fidelities[1].colour: unknown key; allowed:"),
    (lambda c: c.update(fidelities=["tiny", {"cost": 300}]), "fidelities[1].preset: is required"),
    (lambda c: c.update(fidelities=["tiny", {"preset": "quick", "initial": 1}]), "fidelities[1].initial: the target fidelity needs at least 2"),
    (lambda c: c.update(fidelities=[{"preset": "tiny", "initial": -3}, "quick"]), "fidelities[0].initial: must be an integer ≥ 0"),
    (lambda c: c.update(fidelities=[7, "quick"]), "fidelities[0]: must be a preset name or a mapping"),
    (lambda c: c.update(fidelities=["tiny", "quick"], cell={}), "acquisition: 'qei' proposes at one fidelity; with fidelities use"),
    (lambda c: c.update(fidelities=["tiny", "quick"], acquisition="mfei", cell={"preset": "paper"}),
     "cell.preset: is 'paper', but the campaign's target fidelity (the last of fidelities) is 'quick'"),
    (lambda c: c.update(fidelities=["tiny", "quick"], acquisition="mfkg", cell={"preset": "quick"},
                        surrogate={"model": "composite"}),
     "surrogate.model: mfkg (BoTorch's knowledge gradient) needs one model of the distance"),
    (lambda c: c.update(acquisition="mfei"), "acquisition: 'mfei' chooses among fidelities; name them under fidelities"),
]


@pytest.mark.parametrize("change, message", CASES, ids=[m.split(":")[0] + f"-{i}" for i, (_, m) in enumerate(CASES)])
def test_bad_config_is_refused_with_exit_2_and_nothing_written(tmp_path, capsys, change, message):
    path = write_double_campaign(tmp_path)
    config = yaml.safe_load(path.read_text())
    change(config)
    path.write_text(yaml.dump(config))
    before = sorted(p.name for p in tmp_path.rglob("*"))
    code = main(["run", str(path)])
    err = capsys.readouterr().err
    assert code == 2
    assert message in err, err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing written, no store created


def test_yaml_that_is_not_a_mapping_and_broken_yaml(tmp_path, capsys):
    path = tmp_path / "c.yaml"
    path.write_text("- just\n- a list\n")
    assert main(["run", str(path)]) == 2 and "must be a mapping" in capsys.readouterr().err
    path.write_text("name: [unclosed\n")
    assert main(["run", str(path)]) == 2 and "not valid YAML" in capsys.readouterr().err
    assert main(["run", str(tmp_path / "nope.yaml")]) == 2 and "campaign file not found" in capsys.readouterr().err


def test_bad_config_leaves_an_existing_store_untouched(tmp_path):
    path = write_double_campaign(tmp_path, budget={"initial": 2, "iterations": 0})
    assert calibrax_cli("run", str(path)).returncode == 0
    store = tmp_path / "runs/double.h5"
    digest = hashlib.sha256(store.read_bytes()).hexdigest()
    config = yaml.safe_load(path.read_text())
    config["parameters"]["sliding_friction"]["low"] = 2.0
    path.write_text(yaml.dump(config))
    proc = calibrax_cli("run", str(path))
    assert proc.returncode == 2 and "parameters.sliding_friction: low must be < high" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert hashlib.sha256(store.read_bytes()).hexdigest() == digest


def test_check_prints_resolved_settings_and_writes_nothing(tmp_path):
    path = write_double_campaign(tmp_path)
    proc = calibrax_cli("run", str(path), "--check")
    assert proc.returncode == 0, proc.stderr
    assert "simulator: analytic_double" in proc.stdout and "particles" in proc.stdout and "OK" in proc.stdout
    assert not (tmp_path / "runs").exists()


def test_a_store_of_another_campaign_is_refused(tmp_path):
    path = write_double_campaign(tmp_path, budget={"initial": 2, "iterations": 0})
    assert calibrax_cli("run", str(path)).returncode == 0
    config = yaml.safe_load(path.read_text())
    config["parameters"]["sliding_friction"]["high"] = 0.8
    path.write_text(yaml.dump(config))
    proc = calibrax_cli("run", str(path))
    assert proc.returncode == 2 and "different settings" in proc.stderr


def test_procedure_mapping_overrides_fields_of_its_preset(tmp_path):
    """``cell.procedure: {preset, field: value}`` (as docs/reference/campaign-file.md documents) changes those fields
    and keeps the preset's others; a bad field value names its key."""
    from calibrax.core.config import load_config

    path = write_double_campaign(tmp_path, cell={"preset": "tiny", "procedure": {
        "preset": "astm_d7891", "shear_rotation": 0.05, "shear_stresses": [5000, 4000, 3000]}})
    spec = load_config(path).spec
    assert spec.procedure.shear_rotation == 0.05
    assert spec.procedure.shear_stresses == (5000.0, 4000.0, 3000.0)
    assert spec.procedure.preshear_stress == 9000.0  # from astm_d7891
    assert spec.procedure.rotation_rate == 6.0  # from the tiny fidelity preset
    bad = write_double_campaign(tmp_path, cell={"procedure": {"preset": "paper", "shear_rotation": -1}})
    proc = calibrax_cli("run", str(bad), "--check")
    assert proc.returncode == 2 and "cell.procedure.shear_rotation" in proc.stderr, proc.stderr


@pytest.mark.parametrize("procedure, key", [
    ({"steady_tolerance": -0.05}, "cell.procedure.steady_tolerance"),
    ({"preshear_rotation": 0.3, "preshear_max_rotation": 0.2}, "cell.procedure.preshear_max_rotation"),
])
def test_a_bad_steady_state_criterion_exits_2_naming_the_field(tmp_path, procedure, key):
    """Before anything runs: the store is not even created."""
    bad = write_double_campaign(tmp_path, cell={"preset": "tiny", "procedure": {"preset": "paper", **procedure}})
    proc = calibrax_cli("run", str(bad))
    assert proc.returncode == 2 and key in proc.stderr, proc.stderr
    assert not list(tmp_path.rglob("*.h5"))


@pytest.mark.parametrize("enqueue, key", [
    ([{"youngs_modulus": 2e10}], "enqueue[0].sliding_friction"),
    ([{"youngs_modulus": 2e10, "sliding_friction": 1.5}], "enqueue[0].sliding_friction"),
    ([{"youngs_modulus": 2e10, "sliding_friction": 0.3, "density": 1.0}], "enqueue[0].density"),
    ({"youngs_modulus": 2e10}, "enqueue"),
])
def test_bad_enqueued_points_name_the_key(tmp_path, enqueue, key):
    from calibrax import load_config
    from calibrax.errors import ConfigError
    from tests.conftest import write_double_campaign

    with pytest.raises(ConfigError) as err:
        load_config(write_double_campaign(tmp_path, enqueue=enqueue))
    assert err.value.key == key


@pytest.mark.parametrize("surrogate, key", [({"transform": "log"}, "surrogate.transform"),
                                            ({"noise": "none"}, "surrogate.noise"),
                                            ({"model": "kriging"}, "surrogate.model"),
                                            ({"kernel": "rbf"}, "surrogate.kernel")])
def test_bad_surrogate_options_name_the_key(tmp_path, surrogate, key):
    from calibrax import load_config
    from calibrax.errors import ConfigError
    from tests.conftest import write_double_campaign

    with pytest.raises(ConfigError) as err:
        load_config(write_double_campaign(tmp_path, surrogate=surrogate))
    assert err.value.key == key


def test_a_field_added_later_leaves_the_search_hash_of_older_stores_alone(tmp_path):
    """geometry.wall_rolling_friction (issue 22) at its default does not enter the search hash, so a
    store made before the field existed resumes; set, it does."""
    from calibrax import load_config
    from tests.conftest import write_double_campaign

    config = load_config(write_double_campaign(tmp_path))
    older = {k: v for k, v in config.resolved.items()}
    older["cell"] = {**older["cell"], "geometry": {k: v for k, v in older["cell"]["geometry"].items()
                                                   if k != "wall_rolling_friction"}}
    import dataclasses

    assert dataclasses.replace(config, resolved=older).search_hash() == config.search_hash()
    changed = load_config(write_double_campaign(tmp_path, cell={"preset": "tiny",
                                                                "geometry": {"wall_rolling_friction": 0.1}}))
    assert changed.search_hash() != config.search_hash()


def test_an_experiment_presheared_at_another_stress_than_the_cell_exits_2_naming_the_procedure(tmp_path):
    """The FT4's 3 kPa test against the paper's 15 kPa procedure would compare two different loci:
    refused, naming cell.procedure and the preset that matches; accepted with that preset."""
    import shutil

    from calibrax.core.config import load_config

    snippets = Path(__file__).resolve().parents[2] / "docs" / "_snippets"
    for name in ("b4c-3kpa.yaml", "b4c-3kpa-points.csv"):
        shutil.copy(snippets / name, tmp_path / name)
    wrong = write_double_campaign(tmp_path, experiment="b4c-3kpa.yaml")
    proc = calibrax_cli("run", str(wrong), "--check")
    assert proc.returncode == 2, proc.stderr
    assert "cell.procedure" in proc.stderr and "3 kPa" in proc.stderr and "'ft4_3kpa'" in proc.stderr, proc.stderr
    right = write_double_campaign(tmp_path, experiment="b4c-3kpa.yaml", cell={"preset": "tiny", "procedure": "ft4_3kpa"})
    assert load_config(right).spec.procedure.preshear_stress == 3000.0
