"""The shear test as a list of stages (issue 49): the FT4 test's stages built from a spec, and core's
interpreter running them over a second engine written from :class:`ShearCellEngine` alone (a toy: a
still bed whose head holds its load exactly), without numba_dem."""

from __future__ import annotations

import copy
import logging
import math

import numpy as np
import pytest

from calibrax.core.sheartest import Provenance, ShearCellSpec, ShearTestResult
from calibrax.core.sheartest.engine_interface import ShearCellEngine
from calibrax.core.sheartest.procedure_stages import (Compress, Consolidate, Fork, InsertBlades, Pour, Rotate, Settle,
                                                      shear_test_stages)
from calibrax.core.sheartest.stage_records import (CompressRecord, ForkRecord, PourRecord, RotateRecord,
                                                   summarise)
from calibrax.core.sheartest.engine_control import RunLog
from calibrax.core.sheartest.stage_runner import StageRunner

RAMP = (2.0e3, 5.0e3, 10.0e3)


def test_the_ft4_test_as_stages():
    spec = ShearCellSpec.preset("tiny")
    p = spec.procedure
    stages = shear_test_stages(spec)
    assert stages[:3] == (Pour(), InsertBlades(p.preshear_stress), Consolidate(p.preshear_stress))
    rest = stages[3:]
    expected = []
    for k, sigma in enumerate(p.shear_stresses):
        expected += [Settle(p.preshear_stress)] if k else []
        expected += [Rotate("preshear", p.preshear_stress, p.preshear_rotation, True), Settle(sigma),
                     Rotate("shear", sigma, p.shear_rotation)]
    assert list(rest) == expected
    ramped = shear_test_stages(spec.replace(procedure={"compressibility_stresses": RAMP}))
    assert ramped[1] == Fork((Compress(RAMP),)) and ramped[2:] == stages[1:]


class ToyEngine:
    """A bed that never moves; the head comes down at its speed limit onto the highest particle's
    top (blades or not) and then carries exactly its servo's load; the bed opposes a torque of
    0.5 × the load's moment, against the rotation."""

    shear_speed_limit = 1.0

    def __init__(self, spec: ShearCellSpec):
        self.time_step, self.contact_modulus = spec.time_step, 1.0e9
        r, rc = spec.radius, spec.geometry.vessel_diameter / 2.0
        grid = np.arange(-rc + r, rc - r, 2 * r)
        layers = np.arange(r, spec.geometry.fill_height, 2 * r)
        pts = np.array([(x, y, z) for x in grid for y in grid for z in layers if math.hypot(x, y) < rc - r])
        self.positions, self.velocities = pts, np.zeros_like(pts)
        self.radii = np.full(len(pts), r)
        self.masses = 4.0 / 3.0 * math.pi * r**3 * spec.material.density * np.ones(len(pts))
        self.floor = float(np.max(pts[:, 2]) + r)
        self.head_r = spec.geometry.head_radius
        self.parked = 10.0 * spec.geometry.fill_height  # the head's height, m, until it is placed
        self.state = {"t": 0.0, "z": self.parked, "placed": False, "phi": 0.0, "omega": 0.0, "force": 0.0,
                      "vmax": 0.0, "acc": [0.0, 0.0, 0]}
        self.regime = "pour"

    time = property(lambda self: self.state["t"])
    head_height = property(lambda self: self.state["z"])
    head_angle = property(lambda self: self.state["phi"])

    def advance(self, steps: int) -> None:
        s, dt = self.state, steps * self.time_step
        s["t"] += dt
        s["phi"] += s["omega"] * dt
        if s["placed"]:
            s["z"] = max(self.floor, s["z"] - s["vmax"] * dt)
        load = s["force"] if s["z"] <= self.floor else 0.0
        s["acc"][0] += load * steps
        s["acc"][1] += 0.5 * load * self.head_r * np.sign(s["omega"]) * steps
        s["acc"][2] += steps

    def place_head(self, height: float, blades: bool) -> None:
        self.state["z"], self.state["placed"] = height, True

    def set_servo_gains(self, mass: float, damping: float, tau_ref: float) -> None:
        assert mass > 0 and damping > 0 and tau_ref > 0

    def set_servo(self, force: float, speed_limit: float) -> None:
        self.state["force"], self.state["vmax"] = force, speed_limit

    def set_rotation_rate(self, rate: float) -> None:
        self.state["omega"] = rate

    def set_friction(self, regime: str) -> None:
        assert regime in ("pour", "insertion", "material")
        self.regime = regime

    def take_head_load(self) -> tuple[float, float]:
        f, t, n = self.state["acc"]
        self.state["acc"] = [0.0, 0.0, 0]
        return (f / n, t / n) if n else (math.nan, math.nan)

    def snapshot(self) -> object:
        return copy.deepcopy(self.state)

    def restore(self, snapshot: object) -> None:
        self.state = snapshot


def test_a_second_engine_runs_the_whole_test_through_the_interface():
    spec = ShearCellSpec.preset("tiny").replace(procedure={"compressibility_stresses": RAMP}).validate()
    engine = ToyEngine(spec)
    assert isinstance(engine, ShearCellEngine)
    runner = StageRunner(spec, engine, RunLog(logging.getLogger("test_procedure_stages")))
    records = runner.run()
    assert isinstance(records[0], PourRecord) and isinstance(records[1], ForkRecord)
    ramp = records[1].records[0]
    assert isinstance(ramp, CompressRecord) and ramp.heights == pytest.approx((engine.floor,) * 3) and all(ramp.settled)
    assert engine.regime == "material"
    summary = summarise(records)
    assert len(summary.steps) == 2 * len(spec.procedure.shear_stresses)
    assert [s.kind for s in summary.steps] == ["preshear", "shear"] * len(spec.procedure.shear_stresses)
    assert len(summary.bulk_density) == len(spec.procedure.shear_stresses)
    assert summary.insertion_gap == pytest.approx(0.0) and summary.consolidation_time > 0
    assert summary.sigma_errors == pytest.approx([0.0] * len(summary.steps))
    assert runner.warnings == []
    result = ShearTestResult.from_steps(spec, summary.steps, summary.bulk_density,
                                        Provenance("toy", "0", spec.spec_hash(), 0, 0.0, len(engine.radii)),
                                        runner.warnings, conditioned_bulk_density=summary.conditioned_bulk_density,
                                        compression_height=summary.compression_height)
    # τ/σ = 0.5 × 3/2 of the toy's torque law, the same in every step
    area = math.pi * spec.geometry.head_radius**2
    expected = 0.5 * spec.geometry.head_radius * area * 3 / (2 * math.pi * spec.geometry.head_radius**3)
    assert expected == pytest.approx(0.75)
    assert result.peak_shear_stress / result.peak_normal_stress == pytest.approx(expected)
    assert isinstance(records[-1], RotateRecord) and records[-1].step.kind == "shear"


def test_summarise_reads_forks_and_keeps_order():
    spec = ShearCellSpec.preset("tiny")
    engine = ToyEngine(spec)
    runner = StageRunner(spec, engine, RunLog(logging.getLogger("test_procedure_stages")))
    records = runner.run((Pour(), Fork((Compress((1.0e3,)), Compress((2.0e3,))))))
    assert engine.head_height == engine.parked  # the fork's head placement was undone
    assert summarise(records).compression_height == pytest.approx([engine.floor, engine.floor])


def test_branched_steps_are_one_preshear_and_a_fork_per_shear_stress():
    spec = ShearCellSpec.preset("tiny").replace(procedure={"branches": True})
    p = spec.procedure
    stages = shear_test_stages(spec)
    assert stages[:4] == (Pour(), InsertBlades(p.preshear_stress), Consolidate(p.preshear_stress),
                          Rotate("preshear", p.preshear_stress, p.preshear_rotation, True))
    assert stages[4:] == tuple(Fork((Settle(s), Rotate("shear", s, p.shear_rotation))) for s in p.shear_stresses)


def test_a_branched_test_gives_the_result_of_the_same_shape():
    """Every shear step is paired with the one preshear its branch started from: the result holds
    a preshear and a shear step per shear stress, as the sequential test's does, and the branches
    run on the presheared bed (each fork puts it back)."""
    spec = ShearCellSpec.preset("tiny").replace(procedure={"branches": True}).validate()
    engine = ToyEngine(spec)
    runner = StageRunner(spec, engine, RunLog(logging.getLogger("test_procedure_stages")))
    records = runner.run()
    n = len(spec.procedure.shear_stresses)
    assert sum(isinstance(r, ForkRecord) for r in records) == n
    summary = summarise(records)
    assert [s.kind for s in summary.steps] == ["preshear", "shear"] * n
    preshears = summary.steps[0::2]
    assert all(s is preshears[0] for s in preshears)
    assert [s.target_stress for s in summary.steps[1::2]] == pytest.approx(list(spec.procedure.shear_stresses))
    assert summary.bulk_density == [summary.bulk_density[0]] * n
    result = ShearTestResult.from_steps(spec, summary.steps, summary.bulk_density,
                                        Provenance("toy", "0", spec.spec_hash(), 0, 0.0, len(engine.radii)))
    assert result.peak_shear_stress.shape == result.preshear_shear_stress.shape == (n,)
