"""YADE backend: bad input is refused before anything is written; a missing binary is reported."""

from __future__ import annotations

import json
import math

import pytest
from calibrax_yade import YadeSimulator
from calibrax_yade.plugin import calibrax_simulators
from calibrax_yade.runner import check_numbers

from calibrax.core.sheartest import Material, ShearCellSpec
from calibrax.errors import ConfigError, EngineNotFound, SpecError

pytestmark = pytest.mark.yade


def _tiny(**changes):
    return ShearCellSpec.preset("tiny").replace(**changes)


@pytest.mark.parametrize("changes", [
    {"material": {"youngs_modulus": math.nan}},
    {"material": {"sliding_friction": "0.5"}},
    {"radius": math.inf},
    {"procedure": {"rotation_rate": "fast"}},
    {"numerics": {"dt_fraction": math.nan}},
])
def test_bad_numbers_are_refused_before_any_file(tmp_path, changes):
    workdir = tmp_path / "run"
    with pytest.raises(SpecError):
        YadeSimulator().simulate(_tiny(**changes), workdir)
    assert not workdir.exists()


def test_parameter_file_accepts_only_finite_numbers():
    """Numbers, and of text only the script's stage names and record kinds (runner.WORDS)."""
    check_numbers({"a": 1.0, "b": [1, 2.5], "c": {"d": 3}, "stages": [{"stage": "rotate", "kind": "shear"}]})
    for bad in ({"a": math.nan}, {"a": "1"}, {"a": [1.0, math.inf]}, {"a": True}, {"a": None}, {"a b": 1.0},
                {"stage": "fork"}, {"stage": "pour; import os"}):
        with pytest.raises(SpecError):
            check_numbers(bad)


def test_a_fixed_preshear_builds_a_parameter_file_the_script_takes():
    """A fixed preshear (no cap: preshear_max_rotation None) has no steadiness schedule; the
    parameter file says so with an empty list, which the script reads as "no check", not with
    None, which the file's number check refuses (every full-tier YADE run on a fixed preshear
    failed so)."""
    from calibrax_yade.simulator import build_params

    params = build_params(_tiny(procedure={"preshear_max_rotation": None}))
    assert params["steady_schedule"] == []
    check_numbers(params)
    capped = build_params(_tiny())["steady_schedule"]
    assert len(capped) == 4 and all(isinstance(v, int) and v > 0 for v in capped)


@pytest.mark.parametrize("changes", [
    {},
    {"procedure": {"preshear_max_rotation": None}},
    {"procedure": {"shear_stresses": (9000.0,)}},
])
def test_the_parameter_file_holds_cores_stage_list(tmp_path, changes):
    """The script runs core's shear_test_stages as written to params.json (plain data read back
    equal), not a sequence of its own; the smoke test's list too."""
    from calibrax.core.sheartest.procedure_stages import shear_test_stages
    from calibrax_yade.runner import write_params
    from calibrax_yade.simulator import build_params, stages_from_params

    from tests.bank import smoke_spec

    for spec in (_tiny(**changes), smoke_spec()):
        path = write_params(tmp_path / "params.json", build_params(spec))
        written = json.loads(path.read_text())["stages"]
        assert stages_from_params(written) == shear_test_stages(spec)
        assert all(isinstance(v, float) for rec in written for k, v in rec.items() if k not in ("stage", "kind"))


def test_a_compressibility_fork_is_refused_before_yade_starts(tmp_path):
    """YADE has no compressibility test: a spec with a ramp is refused before any file is written,
    and a Fork or Compress stage reaching the stage writer is refused naming the stage."""
    from calibrax.core.sheartest.procedure_stages import Compress, Fork, Pour
    from calibrax_yade.simulator import stage_params

    ramp = _tiny(procedure={"compressibility_stresses": (1.0e3, 2.0e3)})
    with pytest.raises(ConfigError, match="compressibility_test"):
        YadeSimulator().simulate(ramp, tmp_path / "f")
    assert not (tmp_path / "f").exists()
    for stage in (Fork((Compress((1.0e3,)),)), Compress((1.0e3,))):
        with pytest.raises(SpecError, match=type(stage).__name__) as err:
            stage_params((Pour(), stage))
        assert err.value.key == "procedure.compressibility_stresses"


def test_unmodelled_effects_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="cohesion"):
        YadeSimulator().simulate(_tiny(material=Material(cohesion_energy_density=1e3)), tmp_path / "c")
    with pytest.raises(SpecError, match="rolling"):
        YadeSimulator().simulate(_tiny(geometry={"base_rolling_friction": 0.1}), tmp_path / "r")
    assert not (tmp_path / "c").exists() and not (tmp_path / "r").exists()


def test_a_wall_rolling_friction_yade_cannot_give_is_refused(tmp_path):
    """YADE has one rolling coefficient: the wall gets it or none (issue 22). Any other value is
    refused, naming the field, before a file is written; 0 and μr reach the script's flag."""
    from calibrax_yade.simulator import build_params

    with pytest.raises(SpecError) as err:
        YadeSimulator().simulate(_tiny(geometry={"wall_friction": 0.3, "wall_rolling_friction": 0.2}), tmp_path / "w")
    assert err.value.key == "geometry.wall_rolling_friction" and not (tmp_path / "w").exists()
    mu_r = _tiny().material.rolling_friction
    assert build_params(_tiny(geometry={"wall_friction": 0.3}))["wall_rolling"] == 1.0
    assert build_params(_tiny(geometry={"wall_friction": 0.3, "wall_rolling_friction": 0.0}))["wall_rolling"] == 0.0
    assert build_params(_tiny(geometry={"wall_rolling_friction": mu_r}))["wall_rolling"] == 1.0
    assert build_params(_tiny())["wall_rolling"] == 0.0


def test_the_consolidation_limit_reaches_the_script():
    """The script reads its minimum and limit from the procedure (at the paper's rate: 0.6 s and
    3.6 s), not a fixed 0.12 s."""
    from calibrax_yade.simulator import build_params

    params = build_params(_tiny(procedure={"rotation_rate": 0.5, "preshear_rotation": 0.3}))
    assert params["consolidation_min_time"] == pytest.approx(0.6)
    assert params["consolidation_time_limit"] == pytest.approx(3.6)


def test_missing_binary_raises_engine_not_found(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("CALIBRAX_YADE", raising=False)
    with pytest.raises(EngineNotFound, match="apt-get install -y yade"):
        YadeSimulator().simulate(_tiny(), tmp_path / "run")
    with pytest.raises(EngineNotFound, match="apt-get install -y yade"):
        YadeSimulator(executable="/nonexistent/yade").version()


def test_plugin_registers_the_simulator():
    (cls,) = calibrax_simulators()
    sim = cls()
    assert sim.name == "yade"
    assert {"wall_friction", "size_distribution", "base_ribs", "rolling_friction"} <= sim.capabilities()
    assert "cohesion" not in sim.capabilities()
    from importlib.metadata import entry_points

    assert any(ep.name == "yade" and ep.value == "calibrax_yade.plugin" for ep in entry_points(group="calibrax"))
