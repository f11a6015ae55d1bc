"""The FT4's density tests on the real engines (issue 34, item 2): the conditioned bulk density of
the poured bed, measured alike by numba_dem and LIGGGHTS, and numba_dem's compressibility ramp
(the head as a flat piston on the poured bed). YADE measures neither and refuses a ramp."""

from __future__ import annotations

import numpy as np
import pytest

from calibrax.core.data.features import result_features
from calibrax.core.sheartest import ShearCellSpec
from calibrax.diagnosis.gap import diagnosis_features
from calibrax.errors import ConfigError
from tests.bank import declare, declare_smoke, smoke_spec

RAMP = (1000.0, 2000.0, 4000.0, 8000.0, 15000.0)
NUMBA = declare_smoke("numba_dem")
LIGGGHTS = declare_smoke("liggghts")
NUMBA_RAMP = declare("numba_dem/smoke-ramp/s0", "numba_dem",
                     smoke_spec().replace(procedure={"compressibility_stresses": RAMP}))


def solid_fraction(result, spec: ShearCellSpec) -> float:
    return result.conditioned_bulk_density / spec.material.density


@pytest.mark.numba_dem
@pytest.mark.liggghts
@pytest.mark.bank(NUMBA, LIGGGHTS)
def test_both_engines_measure_the_same_conditioned_bulk_density(bank) -> None:
    """The poured bed split at ¾ of its height: a random packing of equal spheres poured with low
    friction (solid fraction 0.55–0.64), and the same on both engines within 3 % (one seed each:
    six numba_dem seeds at tiny scattered by 0.5 %)."""
    spec = smoke_spec()
    numba, liggghts = bank.result(NUMBA), bank.result(LIGGGHTS)
    for result in (numba, liggghts):
        assert 0.55 <= solid_fraction(result, spec) <= 0.64, result.conditioned_bulk_density
        assert result_features(result, spec.procedure.peak_window)["conditioned_bulk_density"] == \
            result.conditioned_bulk_density
        assert result.compression_stress.size == 0 and result.compressibility.size == 0
    assert numba.conditioned_bulk_density == pytest.approx(liggghts.conditioned_bulk_density, rel=0.03)


@pytest.mark.numba_dem
@pytest.mark.bank(NUMBA_RAMP, NUMBA)
def test_the_compressibility_ramp_compresses_the_poured_bed_step_by_step(bank) -> None:
    """The flat piston's ramp on a copy of the poured bed: the bed's height falls at every stress
    (compressibility rises from 0 at the first), the piston held each stress without warning, and
    the shear test ran on the poured bed as it was: its peaks are the plain run's, to the bit."""
    spec = smoke_spec().replace(procedure={"compressibility_stresses": RAMP})
    result, plain = bank.result(NUMBA_RAMP), bank.result(NUMBA)
    assert list(result.compression_stress) == list(RAMP)
    cps = result.compressibility
    assert cps[0] == 0.0 and np.all(np.diff(cps) > 0), cps
    assert cps[-1] < 20.0, cps   # a free-flowing bed of spheres, not a cohesive powder
    assert not [w for w in result.warnings if "compressibility" in w], result.warnings
    assert result.conditioned_bulk_density == plain.conditioned_bulk_density
    features = result_features(result, spec.procedure.peak_window)
    assert features["compressibility_15kPa"] == pytest.approx(cps[-1])
    assert diagnosis_features(features)["compressibility"] == pytest.approx(cps[-1])
    np.testing.assert_array_equal(result.peak_shear_stress, plain.peak_shear_stress)
    np.testing.assert_array_equal(result.bulk_density, plain.bulk_density)


@pytest.mark.yade
def test_yade_refuses_a_compressibility_ramp_naming_it(tmp_path) -> None:
    from calibrax import get_manager

    spec = smoke_spec().replace(procedure={"compressibility_stresses": RAMP})
    with pytest.raises(ConfigError, match="compressibility_test"):
        get_manager().create("simulator", "yade").simulate(spec, tmp_path / "work")
    assert not (tmp_path / "work").exists()
