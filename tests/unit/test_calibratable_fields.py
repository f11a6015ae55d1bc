"""Each spec field declared once (calibrax.core.sheartest.fields): the calibratable parameters,
validation and the capabilities a spec needs all read the declaration, and a point sets the spec
by dotted path, as the diagnosis's effects do."""

from __future__ import annotations

import dataclasses
import math

import pytest

from calibrax.core.search.parameters import CALIBRATABLE, DISPLAY, FIELDS, UNITS, ParameterSpace, spec_path
from calibrax.core.sheartest import Material, ShearCellSpec
from calibrax.core.sheartest.fields import FieldInfo, declared_fields, get_path
from calibrax.core.simulator import required_capabilities
from calibrax.core.studies.simulation_setup import point_spec
from calibrax.diagnosis.effects import Cohesion, SizeDistribution, WallFriction
from calibrax.errors import ConfigError, SpecError


def test_every_calibratable_parameter_is_a_declared_field_with_its_display():
    declared = dict(declared_fields(ShearCellSpec))
    material = {f.name for f in dataclasses.fields(Material)}
    assert set(CALIBRATABLE) == set(UNITS) == set(DISPLAY) == set(FIELDS)
    for name, f in FIELDS.items():
        assert declared[f.path] is f.info and f.info.calibratable
        assert name == f.path or (f.path == f"material.{name}" and name in material)
        assert f.low < f.high and f.symbol and f.display_scale > 0
        default = get_path(ShearCellSpec(), f.path)
        assert default is None or f.info.contains(default), f"{name}'s default {default} lies outside its range"
    # the model's fields are calibratable; the test's (procedure, numerics) are not
    assert {"geometry.wall_friction", "material.rolling_friction", "size_distribution.sigma_log"} <= set(FIELDS)
    assert not any(n.startswith(("procedure.", "numerics.")) for n in FIELDS)
    assert "geometry.vessel_diameter" not in FIELDS


def test_a_declared_range_is_the_one_validation_and_the_search_box_use():
    poisson = FIELDS["poisson_ratio"].info
    assert poisson.interval() == "in [0, 0.5)"
    with pytest.raises(SpecError, match=r"material.poisson_ratio: must lie in \[0, 0.5\), got 0.5"):
        ShearCellSpec.preset("tiny", material={"poisson_ratio": 0.5}).validate()
    with pytest.raises(ConfigError, match=r"bounds must lie in \[0, 0.5\) \(material.poisson_ratio\)"):
        ParameterSpace.from_config({"poisson_ratio": {"low": 0.2, "high": 0.5}})
    ParameterSpace.from_config({"poisson_ratio": {"low": 0.2, "high": 0.49999}})
    with pytest.raises(SpecError, match=r"geometry.base_ribs: must be an integer ≥ 0, got -1"):
        ShearCellSpec.preset("tiny", geometry={"base_ribs": -1}).validate()
    assert FieldInfo(low=0.0, low_open=True).interval() == "> 0"


def test_a_point_sets_the_spec_by_dotted_path_as_the_effects_do():
    base = ShearCellSpec.preset("tiny")
    params = {"sliding_friction": 0.4, "geometry.wall_friction": 0.25, "material.rolling_friction": 0.1}
    spec = point_spec(base, params, seed=7)
    assert (spec.material.sliding_friction, spec.geometry.wall_friction, spec.material.rolling_friction,
            spec.numerics.seed) == (0.4, 0.25, 0.1, 7)
    assert spec_path("sliding_friction") == "material.sliding_friction"
    # the diagnosis's effects set their parameters at the same paths
    assert WallFriction().apply(base, {"wall_friction": 0.25}) == base.with_values({"geometry.wall_friction": 0.25})
    assert Cohesion().apply(base, {"bond_number": 0.3}).material.bond_number == 0.3
    assert SizeDistribution().apply(base, {"sigma_log": 0.2}).size_distribution.kind == "lognormal"
    for effect in (WallFriction(), Cohesion(), SizeDistribution()):
        for p in effect.parameters:
            assert p.path in FIELDS, f"{effect.name}'s {p.name} is not calibratable by its path {p.path}"
    with pytest.raises(SpecError, match="cell.geometry.wall_frictoin: unknown field"):
        base.with_values({"geometry.wall_frictoin": 0.1})


def test_a_parameter_named_twice_and_an_unknown_one_are_refused():
    with pytest.raises(ConfigError, match="material.sliding_friction is named twice"):
        ParameterSpace.from_config({"sliding_friction": {"low": 0.1, "high": 0.9},
                                    "material.sliding_friction": {"low": 0.1, "high": 0.9}})
    with pytest.raises(ConfigError, match=r"parameters.geometry.vessel_diameter: unknown parameter; allowed: "
                                          r"\['geometry.base_friction'"):
        ParameterSpace.from_config({"geometry.vessel_diameter": {"low": 0.01, "high": 0.02}})


def test_the_capabilities_a_spec_needs_come_from_the_declarations():
    base = ShearCellSpec.preset("tiny")
    assert required_capabilities(base) == {"base_ribs"}
    spec = base.with_values({"geometry.wall_friction": 0.2, "material.bond_number": 0.3, "geometry.base_ribs": 0,
                             "size_distribution.kind": "lognormal", "size_distribution.sigma_log": 0.2,
                             "procedure.compressibility_stresses": (1e3, 2e3)})
    assert required_capabilities(spec) == {"wall_friction", "cohesion", "size_distribution", "compressibility_test"}
    declared = {info.capability for _, info in declared_fields(ShearCellSpec)} - {None}
    from calibrax.core.simulator import KNOWN_CAPABILITIES

    assert declared <= KNOWN_CAPABILITIES
    assert math.isinf(FIELDS["geometry.wall_friction"].info.high) is False
