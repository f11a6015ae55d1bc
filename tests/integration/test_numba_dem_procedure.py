"""numba_dem's test procedure against what the spec asks (issue 22): consolidation runs the
procedure's own minimum at a slow rotation rate, and the lateral wall's rolling friction is the
spec's. The real engine, on the ``tiny`` cell, phases run one by one."""

from __future__ import annotations

import logging

import pytest

from calibrax.core.sheartest import ShearCellSpec
from calibrax.core.sheartest.procedure_stages import Consolidate, InsertBlades, Pour
from calibrax_numba_dem.layout import H_PHI, P_MUR_WALL, P_MU_WALL
from calibrax_numba_dem.procedure import RunLog, ShearTestDriver

pytestmark = pytest.mark.numba_dem


def _driver(spec: ShearCellSpec) -> ShearTestDriver:
    return ShearTestDriver(spec.validate(), RunLog(logging.getLogger("test_numba_dem_procedure")))


@pytest.mark.slow
def test_consolidation_at_the_papers_rotation_rate_runs_its_whole_rotation():
    """The ``paper`` preset turns at 0.5 rad/s; its first preshear rotation takes 0.6 s, and a fixed
    0.12 s cut-off stopped every paper consolidation after a fifth of it, with a warning. Shortened
    for CI: the tiny cell at the paper's rate with a 0.075 rad preshear rotation (0.15 s, still past
    the old cut-off)."""
    paper = ShearCellSpec.preset("paper").procedure
    spec = ShearCellSpec.preset("tiny").replace(procedure={"rotation_rate": paper.rotation_rate,
                                                           "preshear_rotation": 0.075})
    one_rotation = 0.075 / paper.rotation_rate  # s
    assert one_rotation > 0.12
    driver = _driver(spec)
    # consolidation proper starts once the blades are in (InsertBlades takes them in at a tenth of
    # the preshear stress)
    driver.run((Pour(), InsertBlades(spec.procedure.preshear_stress)))
    phi, t = float(driver.sys.head[H_PHI]), driver.time
    record = driver.run_stage(Consolidate(spec.procedure.preshear_stress))
    turned, took = float(driver.sys.head[H_PHI]) - phi, driver.time - t
    assert driver.warnings == []
    assert turned >= 0.075 * 0.99, turned
    assert one_rotation <= took < spec.procedure.consolidation_time_limit
    # the log and the provenance report the same
    assert (record.duration, record.rotation) == pytest.approx((took, turned))
    assert record.settled


def test_the_walls_rolling_friction_reaches_the_engine():
    """After the pour, the engine's lateral-wall contact law uses ``geometry.wall_rolling_friction``,
    not the particles' μr (the former rule; the default, unit-tested in test_sheartest), next to the
    wall's sliding friction."""
    spec = ShearCellSpec.preset("tiny").replace(geometry={"wall_friction": 0.3, "wall_rolling_friction": 0.12})
    assert spec.material.rolling_friction != 0.12
    driver = _driver(spec)
    driver.run_stage(Pour())
    assert driver.sys.params[P_MUR_WALL] == pytest.approx(0.12)
    assert driver.sys.params[P_MU_WALL] == pytest.approx(0.3)
