"""ParameterSpace: unit-cube transforms (linear and log) and validation."""

from __future__ import annotations

import numpy as np
import pytest

from calibrax import ParameterSpace
from calibrax.errors import ConfigError


def space():
    return ParameterSpace.from_config({"youngs_modulus": {"low": 5e9, "high": 5e10, "log": True},
                                       "sliding_friction": {"low": 0.1, "high": 0.9}})


def test_unit_cube_roundtrip_and_log_scale():
    s = space()
    nat = np.array([[5e9, 0.1], [5e10, 0.9], [np.sqrt(5e9 * 5e10), 0.5]])
    unit = s.to_unit(nat)
    np.testing.assert_allclose(unit, [[0, 0], [1, 1], [0.5, 0.5]], atol=1e-12)
    np.testing.assert_allclose(s.from_unit(unit), nat, rtol=1e-12)
    assert s.as_dict(nat[2]) == {"youngs_modulus": pytest.approx(1.5811e10, rel=1e-4), "sliding_friction": 0.5}


def test_from_unit_clips_into_the_bounds():
    np.testing.assert_allclose(space().from_unit([[1.2, -0.1]]), [[5e10, 0.1]])


@pytest.mark.parametrize("raw, match", [
    ({"youngs_modulus": {"low": 5e10, "high": 5e9}}, "low must be < high"),
    ({"sliding_friction": {"low": "abc", "high": 0.9}}, "must be a number"),
    ({"stiffness": {"low": 1, "high": 2}}, "unknown parameter"),
    ({"sliding_friction": {"low": 0.1}}, "high: is required"),

    ({"sliding_friction": {"low": 0.0, "high": 0.9, "log": True}}, "> 0"),
    ({"youngs_modulus": {"low": 0.0, "high": 1e9}}, r"bounds must lie in \[100000, 1e\+13\] \(material.youngs_modulus\)"),
    ({}, "non-empty mapping"),
])
def test_bad_parameters(raw, match):
    with pytest.raises(ConfigError, match=match):
        ParameterSpace.from_config(raw)
