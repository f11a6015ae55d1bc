"""The interpreter of a shear test's stages (:mod:`~calibrax.core.sheartest.procedure_stages`) over
any :class:`~calibrax.core.sheartest.engine_interface.ShearCellEngine`: how long each stage runs,
when it is done, what it records, the log and the warnings. The control below the stages (checked
advances, the servo, holds, the torque's turn-back) is :mod:`~calibrax.core.sheartest.engine_control`.

Conventions (shared by every backend, see README): σ = F_head / (π R_head²), the force the
particles exert on the head (disc and blades) over the head's own cross-section;
τ = 3T / (2π R_head³) with T the torque the bed opposes to the head's rotation. Both are averaged
over each sample interval. Rotation is counted from 0 at the start of each step.
"""

from __future__ import annotations

import math
import time

import numpy as np

from calibrax.core.sheartest.density import conditioned_bulk_density
from calibrax.core.sheartest.engine_control import EngineControl, RunLog
from calibrax.core.sheartest.engine_interface import ShearCellEngine
from calibrax.core.sheartest.peaks import preshear_drift, steady_schedule
from calibrax.core.sheartest.physics import GRAVITY, base_layer_bounds, layer_spin, shear_stress_from_torque
from calibrax.core.sheartest.procedure_stages import (Compress, Consolidate, Fork, InsertBlades, Pour, Rotate,
                                                      Settle, Stage, shear_test_stages)
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.core.sheartest.steps import StepRecord
from calibrax.core.sheartest.stage_records import (CompressRecord, ConsolidateRecord, ForkRecord, InsertRecord,
                                                   PourRecord, Record, RotateRecord, SettleRecord)
from calibrax.core.sheartest.stages import (APPROACH_CLEARANCE, APPROACH_SPEED, COMPRESSION_MAX_TIME,
                                            COMPRESSION_MIN_TIME, CONSOLIDATION_LIMIT_FACTOR,
                                            INSERTION_STRESS_FRACTION, INSERTION_TOLERANCE_RADII, POUR_GRAVITY,
                                            POUR_SPEED, insertion_time_limit)


#: the runner's method for each stage kind
STAGE_METHODS = {Pour: "pour", Compress: "compress", InsertBlades: "insert_blades", Consolidate: "consolidate",
                 Settle: "settle", Rotate: "rotate", Fork: "fork"}

__all__ = ["RunLog", "STAGE_METHODS", "StageRunner", "stage_label"]


def stage_label(stage: Stage) -> str:
    """The name a stage's CPU time is counted under: its method's (``pour``, ``settle``,
    ``fork`` …), a rotation's kind (``preshear``, ``shear``)."""
    return stage.kind if isinstance(stage, Rotate) else STAGE_METHODS[type(stage)]


class StageRunner(EngineControl):
    """Runs stages of one :class:`ShearCellSpec` (already validated) on ``engine``, built for it;
    :meth:`run` returns one record per stage (:mod:`~calibrax.core.sheartest.stage_records`)."""

    def __init__(self, spec: ShearCellSpec, engine: ShearCellEngine, log: RunLog):
        super().__init__(spec, engine, log)
        #: CPU seconds spent in each kind of stage so far (:func:`stage_label` → s)
        self.stage_cpu: dict[str, float] = {}

    # ---------------------------------------------------------------- the test
    def run(self, stages: tuple[Stage, ...] | None = None) -> list[Record]:
        """Run ``stages`` (default: the spec's whole test, :func:`shear_test_stages`) in order; then
        warn if the servo missed σ by more than 5 % in any rotation."""
        records = [self.run_stage(stage) for stage in (shear_test_stages(self.spec) if stages is None else stages)]
        bad = [e for e in self.sigma_errors if abs(e) > 0.05]
        if bad:
            self.warnings.append(f"the servo held σ within 5 % of its target in only "
                                 f"{len(self.sigma_errors) - len(bad)} of {len(self.sigma_errors)} steps "
                                 f"(worst {100 * max(bad, key=abs):+.1f} %)")
        return records

    def run_stage(self, stage: Stage) -> Record:
        """Run one stage (by the method :data:`STAGE_METHODS` names, so that a subclass or a
        diagnostic may wrap it); its record. The process's CPU time it took (every thread's) is
        added to :attr:`stage_cpu` under :func:`stage_label` (a Fork's own share is only its
        copies: its stages count under their own labels)."""
        t0 = time.process_time()
        inner = sum(self.stage_cpu.values())
        record = getattr(self, STAGE_METHODS[type(stage)])(stage)
        spent = time.process_time() - t0 - (sum(self.stage_cpu.values()) - inner)
        label = stage_label(stage)
        self.stage_cpu[label] = self.stage_cpu.get(label, 0.0) + spent
        return record

    def stage_cpu_words(self) -> str:
        """Each kind of stage's CPU seconds and share of the test's, for the log."""
        total = sum(self.stage_cpu.values()) or 1.0
        return ", ".join(f"{k} {v:.1f} s ({v / total:.0%})" for k, v in self.stage_cpu.items())


    # ---------------------------------------------------------------- stages
    def pour(self, stage: Pour) -> PourRecord:
        """Settle the column under (boosted) gravity with low friction, then switch to the
        material's friction and normal gravity."""
        e = self.engine
        h0 = float(e.positions[:, 2].max())
        h_target = self.spec.geometry.fill_height
        t_fall = math.sqrt(2.0 * max(h0 - h_target, self.spec.radius) / (GRAVITY * POUR_GRAVITY))
        self.advance(1.5 * t_fall, "pour")
        t_max = 10.0 * t_fall + 0.05
        t_spent = 1.5 * t_fall
        while t_spent < t_max:
            if self.max_speed() < POUR_SPEED:
                break
            self.advance(2.0e-3, "pour")
            t_spent += 2.0e-3
        e.set_friction("material")
        self.advance(3.0e-3, "settle")
        rho = conditioned_bulk_density(e.positions[:, 2], e.radii, self.spec.material.density,
                                       self.spec.bed_cross_section)
        self.log(f"t={self.time:.5f} s poured {len(e.radii)} particles in {t_spent:.4f} s; bed top "
                 f"{self.bed_top() * 1e3:.2f} mm (target fill height {h_target * 1e3:.2f} mm); conditioned bulk "
                 f"density {rho:.0f} kg/m³")
        return PourRecord(conditioned_bulk_density=rho, duration=t_spent)

    def fork(self, stage: Fork) -> ForkRecord:
        """Run the stages on a copy of the state, then put the state back."""
        saved, ceiling = self.engine.snapshot(), self.z_ceiling
        records = tuple(self.run_stage(s) for s in stage.stages)
        self.engine.restore(saved)
        self.z_ceiling = ceiling
        self.log(f"t={self.time:.5f} s the state before {len(stage.stages)} forked stage(s) put back")
        return ForkRecord(records)

    def compress(self, stage: Compress) -> CompressRecord:
        """The FT4's compressibility test: the head, its blades retracted (a flat piston, as the
        FT4's vented piston), comes down onto the bed and compresses it through ``stage.stresses``
        without turning, holding each stress until it has settled (:meth:`hold`, at least
        COMPRESSION_MIN_TIME, at most COMPRESSION_MAX_TIME); the bed's height at each is recorded.
        Run in a :class:`Fork`, so that the shear test runs on the bed the plain test would."""
        e, r = self.engine, self.spec.radius
        e.place_head(self.highest() + 0.1 * r, blades=False)
        self.z_ceiling = e.head_height + 10.0 * r
        e.set_rotation_rate(0.0)
        heights, settled_all = [], []
        for stress in stage.stresses:
            self.tune_servo(stress, self.bed_top())
            self.set_servo(stress, APPROACH_SPEED)
            sigma, settled = self.hold(stress, COMPRESSION_MIN_TIME, COMPRESSION_MAX_TIME, "compressibility test")
            heights.append(float(e.head_height))
            settled_all.append(settled)
            if not settled:
                self.warnings.append(f"compressibility test: the piston was still moving at {stress:.0f} Pa after "
                                     f"{COMPRESSION_MAX_TIME:.3g} s")
            self.log(f"t={self.time:.5f} s compressed at {stress:.0f} Pa: σ = {sigma:.0f} Pa, bed height "
                     f"{e.head_height * 1e3:.3f} mm, bulk density {self.bulk():.0f} kg/m³")
        return CompressRecord(tuple(heights), tuple(settled_all))

    def insert_blades(self, stage: InsertBlades) -> InsertRecord:
        """Place the head with its blade tips APPROACH_CLEARANCE diameters above the bed, tune the
        servo for ``stage.stress``, then take the turning blades into the bed under
        INSERTION_STRESS_FRACTION of it with the insertion's friction on every contact, until the
        head's lower face has come down to the top of the poured bed's highest particle; then
        switch the material's friction back on. Without this the blade edges carried the whole
        preshear stress on the bed's top and never went in (see INSERTION_STRESS_FRACTION)."""
        spec, e = self.spec, self.engine
        r = spec.radius
        top, highest = self.bed_top(), self.highest()
        e.place_head(max(top + APPROACH_CLEARANCE * 2.0 * r, highest + 0.1 * r) + spec.geometry.blade_height,
                     blades=True)
        self.z_ceiling = e.head_height + 10.0 * r
        mass, damp, tau = self.tune_servo(stage.stress, top)
        self.log(f"t={self.time:.5f} s head placed at {e.head_height * 1e3:.2f} mm (bed top {top * 1e3:.2f} mm); "
                 f"servo mass {mass:.3g} kg, damping {damp:.3g} N s/m, tau_ref {tau:.3g} s")
        # the head turns while it descends, so that the blades cut into the bed (as the FT4 does)
        e.set_rotation_rate(spec.procedure.rotation_rate)
        e.set_friction("insertion")
        self.set_servo(INSERTION_STRESS_FRACTION * stage.stress, APPROACH_SPEED)
        t0 = self.time
        t_max = insertion_time_limit(spec, APPROACH_SPEED)
        goal = highest + INSERTION_TOLERANCE_RADII * r
        while e.head_height > goal and self.time - t0 < t_max:
            self.advance(1.0e-3, "blade insertion")
        e.set_friction("material")
        gap = float((e.head_height - highest) / r)
        if e.head_height > goal:
            self.warnings.append(f"blade insertion: after {t_max:.3g} s the head's face was still "
                                 f"{gap:.2f} particle radii above the poured bed's top: the blades "
                                 "are not fully in the bed")
        self.log(f"t={self.time:.5f} s blades inserted in {self.time - t0:.4f} s: head face at "
                 f"{e.head_height * 1e3:.2f} mm, the poured bed's highest particle reached {highest * 1e3:.2f} mm")
        return InsertRecord(gap_radii=gap, duration=self.time - t0)

    def consolidate(self, stage: Consolidate) -> ConsolidateRecord:
        """Consolidate the bed at ``stage.stress`` turning at the rotation rate, for at least one
        preshear rotation (the blades must work their way in and the bed must compact before the
        first preshear is recorded) and until the head has stopped sinking; at most
        ``procedure.consolidation_time_limit``."""
        e, proc = self.engine, self.spec.procedure
        e.set_rotation_rate(proc.rotation_rate)
        self.set_servo(stage.stress, APPROACH_SPEED)
        t0, phi0 = self.time, e.head_angle
        t_max = proc.consolidation_time_limit
        sigma, settled = self.hold(stage.stress, proc.consolidation_min_time, t_max, "consolidation")
        if not settled:
            self.warnings.append(f"consolidation: the head was still moving after {t_max:.3g} s "
                                 f"({CONSOLIDATION_LIMIT_FACTOR:g} × one preshear rotation)")
        e.set_rotation_rate(0.0)
        took, turned = self.time - t0, float(e.head_angle - phi0)
        self.log(f"t={self.time:.5f} s consolidated in {took:.4f} s (head turned {turned:.3f} rad): head at "
                 f"{e.head_height * 1e3:.2f} mm, σ = {sigma:.0f} Pa (target {stage.stress:.0f}), bulk density "
                 f"{self.bulk():.0f} kg/m³")
        return ConsolidateRecord(duration=took, rotation=turned, normal_stress=float(sigma), settled=settled)

    def settle(self, stage: Settle) -> SettleRecord:
        """Unload the residual torque, then hold ``stage.stress`` without rotating for
        ``procedure.settle_time`` so that σ has settled before the rotation restarts."""
        e, proc = self.engine, self.spec.procedure
        back = self.unload_torque()
        self.set_servo(stage.stress, e.shear_speed_limit)
        self.advance(proc.settle_time, "settle")
        e.take_head_load()
        self.advance(min(self.spec.numerics.sample_interval, proc.settle_time), "settle")
        f, torque = e.take_head_load()
        sigma, tau = f / self.area, float(shear_stress_from_torque(torque, self.spec.geometry.head_radius))
        self.log(f"t={self.time:.5f} s settled at {stage.stress:.0f} Pa after turning back {back:.4f} rad: "
                 f"σ = {sigma:.0f} Pa, τ = {tau:.0f} Pa")
        return SettleRecord(turned_back=back, normal_stress=sigma, shear_stress=tau)

    def rotate(self, stage: Rotate) -> RotateRecord:
        """Rotate the head by ``stage.rotation`` rad at the procedure's rate under ``stage.stress``;
        record every sample interval. With ``until_steady`` and a capped procedure, go on past the
        rotation until τ/σ is steady (:func:`~calibrax.core.sheartest.preshear_drift` within the
        procedure's tolerance, checked on the schedule of
        :func:`~calibrax.core.sheartest.steady_schedule`) or the cap."""
        spec, e, kind, stress = self.spec, self.engine, stage.kind, stage.stress
        proc = spec.procedure
        self.set_servo(stress, e.shear_speed_limit)
        rate = proc.rotation_rate
        e.set_rotation_rate(rate)
        phi0 = e.head_angle
        per = max(1, int(round(spec.numerics.sample_interval / self.dt)))
        nsamples = max(2, int(math.ceil(stage.rotation / rate / (per * self.dt))))
        steady = stage.until_steady and proc.preshear_max_rotation is not None
        if steady:
            first, nsamples, _, every = steady_schedule(proc, rate * per * self.dt)
        rec = np.empty((6, nsamples))
        z_low, z_high = base_layer_bounds(spec)
        e.take_head_load()
        for k in range(nsamples):
            e.advance(per)
            f, torque = e.take_head_load()
            rec[0, k] = self.time
            rec[1, k] = e.head_angle - phi0
            rec[2, k] = float(shear_stress_from_torque(torque, spec.geometry.head_radius))
            rec[3, k] = f / self.area
            rec[4, k] = e.head_height
            rec[5, k] = layer_spin(e.positions, e.velocities, z_low, z_high)
            if k % 20 == 0:
                self.check(kind)
            if (steady and k + 1 >= first and (k + 1 - first) % every == 0 and k + 1 < nsamples
                    and preshear_drift(rec[1, :k + 1], rec[2, :k + 1], rec[3, :k + 1], proc.steady_window)
                    <= proc.steady_tolerance):
                rec = rec[:, :k + 1]
                break
        self.check(kind)
        e.set_rotation_rate(0.0)
        step = StepRecord(kind=kind, target_stress=stress, time=rec[0], rotation=rec[1], shear_stress=rec[2],
                          normal_stress=rec[3], bed_height=rec[4], base_spin=rec[5])
        err = float(np.mean(rec[3]) / stress - 1.0)
        self.sigma_errors.append(err)
        self.log(f"t={self.time:.5f} s {kind} at {stress:.0f} Pa: mean σ {np.mean(rec[3]):.0f} Pa "
                 f"({100 * err:+.1f} %), σ sd {np.std(rec[3]):.0f} Pa, τ max {np.max(rec[2]):.0f} Pa, "
                 f"τ end {np.mean(rec[2][-max(1, rec.shape[1] // 5):]):.0f} Pa, head {e.head_height * 1e3:.2f} mm, "
                 f"turned {rec[1, -1]:.3f} rad")
        return RotateRecord(step=step, bulk_density=self.bulk(), sigma_error=err)
