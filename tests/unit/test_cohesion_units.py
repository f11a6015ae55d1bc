"""Cohesion in physical units (issue 34): the SJKR pull-off law, the Bond number and its
conversion to the energy density, the spec field that carries it, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from calibrax.core.sheartest import ShearCellSpec
from calibrax.core.sheartest.cohesion import (bond_number_energy_density, effective_modulus,
                                              energy_density_bond_number, mean_contact_force, sjkr_pull_off_force,
                                              sjkr_pull_off_overlap)
from calibrax.errors import SpecError
from tests.conftest import calibrax_cli, write_double_campaign

E, NU, R, SIGMA = 25e9, 0.25, 0.9e-3, 15e3


def test_pull_off_is_the_largest_attraction_of_the_sjkr_law() -> None:
    """The closed form against a numerical maximum of k·2πR*δ − 4/3 E* √R* δ^(3/2)."""
    e_star, reff, k = effective_modulus(E, NU), 0.5 * R, 1.3e8
    attraction = lambda d: -(k * 2 * math.pi * reff * d - 4 / 3 * e_star * math.sqrt(reff) * d**1.5)  # noqa: E731
    best = minimize_scalar(attraction, bounds=(0.0, 10 * sjkr_pull_off_overlap(k, reff, e_star)), method="bounded",
                           options={"xatol": 1e-16})
    assert -best.fun == pytest.approx(sjkr_pull_off_force(k, reff, e_star), rel=1e-6)
    assert best.x == pytest.approx(sjkr_pull_off_overlap(k, reff, e_star), rel=1e-3)


def test_bond_number_and_energy_density_are_inverse_and_in_the_stated_units() -> None:
    # the mean contact force at the preshear stress: π d² σ / (φ Z) with φ Z = 3
    assert mean_contact_force(R, SIGMA) == pytest.approx(math.pi * (2 * R) ** 2 * SIGMA / 3.0)
    for bond in (0.05, 0.6, 2.0, 10.0):
        k = bond_number_energy_density(bond, R, E, NU, SIGMA)
        assert energy_density_bond_number(k, R, E, NU, SIGMA) == pytest.approx(bond, rel=1e-12)
        assert sjkr_pull_off_force(k, 0.5 * R, effective_modulus(E, NU)) == pytest.approx(
            bond * mean_contact_force(R, SIGMA), rel=1e-12)
    # k grows as Bo^(1/3); the former diagnosis range (k ≤ 3·10⁷ J/m³) was Bo ≈ 0.012 at Table 1
    assert bond_number_energy_density(8.0, R, E, NU, SIGMA) == pytest.approx(
        2 * bond_number_energy_density(1.0, R, E, NU, SIGMA))
    assert energy_density_bond_number(3e7, R, E, NU, SIGMA) == pytest.approx(0.0125, abs=5e-4)
    assert 1.2e8 < bond_number_energy_density(1.0, R, E, NU, SIGMA) < 1.4e8
    assert bond_number_energy_density(0.0, R, E, NU, SIGMA) == 0.0


def test_the_spec_converts_its_bond_number_at_its_own_material_and_15_kpa_whatever_the_procedure() -> None:
    spec = ShearCellSpec.preset("tiny").replace(material={"bond_number": 0.6, "youngs_modulus": 1e10})
    assert spec.is_cohesive()
    assert spec.sjkr_energy_density() == pytest.approx(
        bond_number_energy_density(0.6, spec.radius, 1e10, spec.material.poisson_ratio, 15e3))
    # one Bo is one powder: the FT4's 3 kPa test (and any other preshear) gets the same k, so its
    # contacts feel five times the Bond number that the 15 kPa test's feel
    for low in (spec.replace(procedure={"preshear_stress": 3e3, "shear_stresses": (2e3, 1.5e3, 1e3)}),
                ShearCellSpec.preset("tiny", "ft4_3kpa").replace(material={"bond_number": 0.6, "youngs_modulus": 1e10})):
        assert low.sjkr_energy_density() == pytest.approx(spec.sjkr_energy_density(), rel=1e-12)
        k = low.sjkr_energy_density()
        assert energy_density_bond_number(k, low.radius, 1e10, low.material.poisson_ratio,
                                          low.procedure.preshear_stress) == pytest.approx(5 * 0.6)
    plain = ShearCellSpec.preset("tiny").replace(material={"cohesion_energy_density": 2e7})
    assert plain.sjkr_energy_density() == 2e7 and plain.is_cohesive()
    assert not ShearCellSpec.preset("tiny").is_cohesive()


def test_spec_hashes_made_before_the_field_existed_stay() -> None:
    """The seed-noise caches and the studies' stores are named by spec hashes: a Bond number of 0
    leaves every hash as it was (these two name the caches measured before the field existed)."""
    assert ShearCellSpec.preset("tiny").spec_hash() == "e63518d9b579362c"
    assert ShearCellSpec.preset("quick").spec_hash() == "898a207648f661bf"
    assert ShearCellSpec.preset("tiny").replace(material={"bond_number": 0.5}).spec_hash() != "e63518d9b579362c"


@pytest.mark.parametrize("material, message", [
    ({"bond_number": -0.5}, r"must lie in \[0, 100\], got -0.5"),
    ({"bond_number": float("nan")}, "finite"),
    ({"bond_number": 0.5, "cohesion_energy_density": 1e7}, "not both"),
])
def test_bad_bond_number_names_the_field(material: dict, message: str) -> None:
    with pytest.raises(SpecError, match=message) as err:
        ShearCellSpec.preset("tiny").replace(material=material).validate()
    assert err.value.key == "material.bond_number"


def test_a_negative_bond_number_in_a_campaign_exits_2_naming_it(tmp_path) -> None:
    path = write_double_campaign(tmp_path, material={"bond_number": -1.0})
    proc = calibrax_cli("run", str(path), "--check")
    assert proc.returncode == 2, proc.stderr
    assert "material.bond_number: must lie in [0, 100], got -1.0" in proc.stderr
    assert not (tmp_path / "runs").exists()
