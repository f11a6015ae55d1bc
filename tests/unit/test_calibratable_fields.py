"""The one registry of calibratable parameters (calibrax.core.search.parameters.FIELDS) against the spec."""

from __future__ import annotations


def test_every_calibratable_parameter_is_a_material_field_with_its_display():
    import dataclasses

    from calibrax.core.search.parameters import CALIBRATABLE, DISPLAY, FIELDS, UNITS
    from calibrax.core.sheartest import Material

    material = {f.name for f in dataclasses.fields(Material)}
    assert set(FIELDS) <= material
    assert set(CALIBRATABLE) == set(UNITS) == set(DISPLAY) == set(FIELDS)
    for f in FIELDS.values():
        assert f.low < f.high and f.symbol and f.display_scale > 0
        default = getattr(Material(), f.name)
        assert f.low <= default <= f.high, f"{f.name}'s default {default} lies outside its range"
