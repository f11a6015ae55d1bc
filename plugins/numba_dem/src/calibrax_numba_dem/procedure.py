"""The FT4 shear-test procedure on a :class:`DEMSystem`: pour, consolidate, then preshear and
shear for every normal stress, recording the head's torque and normal force.

Conventions (shared by every backend, see README): σ = F_head / (π R_head²), the force the
particles exert on the head (disc and blades) over the head's own cross-section;
τ = 3T / (2π R_head³) with T the torque the bed opposes to the head's rotation. Both are averaged
over each sample interval. Rotation is counted from 0 at the start of each step.
"""

from __future__ import annotations

import copy
import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np
from calibrax.core.sheartest.packing import initial_packing
from calibrax.core.sheartest.servo import servo_gains
from calibrax.core.sheartest import (APPROACH_CLEARANCE, APPROACH_SPEED, COMPRESSION_MAX_TIME,
                                     COMPRESSION_MIN_TIME,
                                     CONSOLIDATION_LIMIT_FACTOR, GRAVITY,
                                     INSERTION_FRICTION, INSERTION_STRESS_FRACTION, INSERTION_TOLERANCE_RADII,
                                     MAX_SPEED, POUR_FRICTION, POUR_GRAVITY, POUR_SPEED, UNLOAD_MAX_ROTATION,
                                     insertion_time_limit,
                                     ShearCellSpec, StepRecord, base_layer_bounds, bed_top, conditioned_bulk_density,
                                     layer_spin,
                                     preshear_drift, shear_stress_from_torque, steady_schedule)
from calibrax.errors import SimulationFailed

from .contact import beta_from_restitution, effective_moduli
from .engine import DEMSystem, make_params
from .layout import (H_DAMP, H_FTARGET, H_MASS, H_MODE, H_OMEGA, H_PHI, H_TAU_REF, H_TIME, H_VMAX,
                     H_VREF, H_VZ, H_Z, P_GZ, P_NBLADES, P_MU, P_MU_BASE, P_MU_HEAD, P_MU_WALL, P_MUR, P_MUR_BASE,
                     P_MUR_HEAD, P_MUR_WALL, P_USE_HEAD)

#: servo speed limit while settling and shearing, m/s: high enough never to act, because a limit
#: that clips the head's response to contact spikes rectifies them and biases σ upwards (the pour,
#: approach, insertion and escape constants are every backend's: calibrax.core.sheartest.stages)
SHEAR_SPEED_LIMIT = 1.0


@dataclass
class RunLog:
    """A text log kept in the work directory; its tail goes into :class:`SimulationFailed`."""

    logger: logging.Logger
    lines: list[str] = field(default_factory=list)

    def __call__(self, msg: str) -> None:
        self.lines.append(msg)
        self.logger.info(msg)

    def tail(self, n: int = 40) -> str:
        return "\n".join(self.lines[-n:])


class ShearTestDriver:
    """Runs one :class:`ShearCellSpec` (already validated) and collects its steps."""

    def __init__(self, spec: ShearCellSpec, log: RunLog):
        self.spec = spec
        self.log = log
        g, m = spec.geometry, spec.material
        self.dt = spec.time_step
        self.rc = g.vessel_diameter / 2.0
        self.area = math.pi * g.head_radius**2
        radii, x, v = initial_packing(spec)
        self.r_mean = float(np.mean(radii))
        e_star, g_star = effective_moduli(m.youngs_modulus, m.poisson_ratio)
        self.e_star = e_star
        mu_b, mur_b = spec.effective_base_friction()
        self.mu_base, self.mur_base = mu_b, mur_b
        wall_mur = spec.effective_wall_rolling_friction()
        params = make_params(
            dt=self.dt, gz=-GRAVITY * POUR_GRAVITY, estar=e_star, gstar=g_star,
            beta=beta_from_restitution(m.restitution), mu=POUR_FRICTION, mur=0.0,
            coh=spec.sjkr_energy_density(), use_cyl=1.0, rc=self.rc, mu_wall=min(g.wall_friction, POUR_FRICTION),
            mur_wall=0.0, use_base=1.0, mu_base=POUR_FRICTION, mur_base=0.0, nribs=g.base_ribs,
            rib_h=g.rib_height, use_head=0.0, head_r=g.head_radius, hub_r=g.hub_radius, blade_h=g.blade_height,
            nblades=g.blade_count, mu_head=spec.effective_head_friction(), mur_head=m.rolling_friction)
        self._wall_mur = wall_mur
        self.sys = DEMSystem(x, radii, m.density, params, v=v)
        self.z_ceiling = float(x[:, 2].max()) + 10.0 * spec.radius
        self.steps: list[StepRecord] = []
        self.bulk_density: list[float] = []
        self.consolidation_time = math.nan  # s, set by consolidate()
        self.consolidation_rotation = math.nan  # rad the head turned while consolidating
        self.insertion_gap = math.nan  # head face above the poured bed's highest particle after insertion, radii
        self.conditioned_bulk_density = math.nan  # kg/m³, set by pour()
        self.compression_height: list[float] = []  # m, the bed's height at each ramp stress (compress())
        self.sigma_errors: list[float] = []
        self.warnings: list[str] = []

    # ---------------------------------------------------------------- helpers
    @property
    def time(self) -> float:
        return float(self.sys.head[H_TIME])

    def _check(self, phase: str) -> None:
        s = self.sys
        if not (np.all(np.isfinite(s.x)) and np.all(np.isfinite(s.v)) and np.isfinite(s.head[H_Z])):
            self.log(f"t={self.time:.5f} s {phase}: NaN in the state")
            raise SimulationFailed(f"NaN in the particle state during {phase}", self.log.tail(), kind="nan")
        vmax = float(np.sqrt(np.max(np.sum(s.v**2, axis=1))))
        rho = np.sqrt(s.x[:, 0] ** 2 + s.x[:, 1] ** 2)
        out = int(np.sum((rho > self.rc + s.rad) | (s.x[:, 2] < -s.rad) | (s.x[:, 2] > self.z_ceiling)))
        if out:
            self.log(f"t={self.time:.5f} s {phase}: {out} particles left the cell")
            raise SimulationFailed(f"{out} particles escaped the cell during {phase}", self.log.tail(),
                                   kind="unstable")
        if vmax > MAX_SPEED:
            self.log(f"t={self.time:.5f} s {phase}: particle speed {vmax:.3g} m/s")
            raise SimulationFailed(f"blow-up during {phase}: a particle reached {vmax:.3g} m/s",
                                   self.log.tail(), kind="unstable")

    def _run(self, duration: float, phase: str, chunk: float = 1.0e-3) -> None:
        nsteps = int(round(duration / self.dt))
        per = max(1, int(round(chunk / self.dt)))
        while nsteps > 0:
            k = min(per, nsteps)
            self.sys.advance(k)
            nsteps -= k
            self._check(phase)

    def bed_top(self) -> float:
        """Height of the bed's surface, m (:func:`calibrax.core.sheartest.bed_top`)."""
        return bed_top(self.sys.x[:, 2], self.sys.rad)

    # ---------------------------------------------------------------- phases
    def pour(self) -> None:
        """Settle the column under (boosted) gravity with low friction, then switch to the
        material's friction and normal gravity."""
        s = self.sys
        h0 = float(s.x[:, 2].max())
        h_target = self.spec.geometry.fill_height
        t_fall = math.sqrt(2.0 * max(h0 - h_target, self.spec.radius) / (GRAVITY * POUR_GRAVITY))
        self._run(1.5 * t_fall, "pour")
        t_max = 10.0 * t_fall + 0.05
        t_spent = 1.5 * t_fall
        while t_spent < t_max:
            vmax = float(np.sqrt(np.max(np.sum(s.v**2, axis=1))))
            if vmax < POUR_SPEED:
                break
            self._run(2.0e-3, "pour")
            t_spent += 2.0e-3
        m, g = self.spec.material, self.spec.geometry
        p = s.params
        p[P_GZ] = -GRAVITY
        p[P_MU] = m.sliding_friction
        p[P_MUR] = m.rolling_friction
        p[P_MU_BASE] = self.mu_base
        p[P_MUR_BASE] = self.mur_base
        p[P_MU_WALL] = g.wall_friction
        p[P_MUR_WALL] = self._wall_mur
        self._run(3.0e-3, "settle")
        self.conditioned_bulk_density = conditioned_bulk_density(s.x[:, 2], s.rad, m.density, self.rc)
        self.log(f"t={self.time:.5f} s poured {s.n} particles in {t_spent:.4f} s; bed top "
                 f"{self.bed_top() * 1e3:.2f} mm (target fill height {h_target * 1e3:.2f} mm); conditioned bulk "
                 f"density {self.conditioned_bulk_density:.0f} kg/m³")

    def _set_servo(self, stress: float, speed_limit: float) -> None:
        h = self.sys.head
        h[H_MODE] = 1.0
        h[H_FTARGET] = stress * self.area
        h[H_VMAX] = speed_limit

    def consolidate(self) -> None:
        """Place the head with its blade tips above the bed, then let the servo take it in,
        turning at the rotation rate, and consolidate the bed at the preshear stress for at least
        one preshear rotation and until the head has stopped sinking."""
        spec, s, h = self.spec, self.sys, self.sys.head
        g = spec.geometry
        top = self.bed_top()
        highest = float(np.max(s.x[:, 2] + s.rad))
        h[H_Z] = max(top + APPROACH_CLEARANCE * 2.0 * spec.radius, highest + 0.1 * spec.radius) + g.blade_height
        self.z_ceiling = h[H_Z] + 10.0 * spec.radius
        bed_mass = float(np.sum(s.mass))
        mass, damp, tau = servo_gains(spec.procedure.preshear_stress, self.area, spec.radius, self.e_star,
                                      top, bed_mass)
        h[H_MASS], h[H_DAMP], h[H_TAU_REF] = mass, damp, tau
        h[H_VZ] = h[H_VREF] = 0.0
        s.params[P_USE_HEAD] = 1.0
        self._set_servo(spec.procedure.preshear_stress, APPROACH_SPEED)
        self.log(f"t={self.time:.5f} s head placed at {h[H_Z] * 1e3:.2f} mm (bed top {top * 1e3:.2f} mm); "
                 f"servo mass {mass:.3g} kg, damping {damp:.3g} N s/m, tau_ref {tau:.3g} s")
        # the head turns while it descends, so that the blades cut into the bed (as the FT4 does)
        h[H_OMEGA] = spec.procedure.rotation_rate
        self.insert_blades(highest)
        self._set_servo(spec.procedure.preshear_stress, APPROACH_SPEED)
        t0 = self.time
        phi0 = h[H_PHI]
        target = spec.procedure.preshear_stress
        # at least one preshear rotation of turning (the blades must work their way in and the bed
        # must compact before the first preshear is recorded), then until the head stops sinking;
        # at most a multiple of that minimum (Procedure.consolidation_time_limit)
        t_max = spec.procedure.consolidation_time_limit
        sigma, settled = self.hold(target, spec.procedure.consolidation_min_time, t_max, "consolidation")
        if not settled:
            self.warnings.append(f"consolidation: the head was still moving after {t_max:.3g} s "
                                 f"({CONSOLIDATION_LIMIT_FACTOR:g} × one preshear rotation)")
        h[H_OMEGA] = 0.0
        self.consolidation_time = self.time - t0
        self.consolidation_rotation = float(h[H_PHI] - phi0)
        self.log(f"t={self.time:.5f} s consolidated in {self.consolidation_time:.4f} s (head turned "
                 f"{self.consolidation_rotation:.3f} rad): head at {h[H_Z] * 1e3:.2f} mm, σ = {sigma:.0f} Pa "
                 f"(target {target:.0f}), bulk density {self.bulk():.0f} kg/m³")

    def hold(self, stress: float, t_min: float, t_max: float, phase: str) -> tuple[float, bool]:
        """Hold ``stress`` (Pa) with the servo until the head has stopped sinking (< 1/200
        diameter in 3 ms) with σ over the last 1 ms within 5 % of it, after at least ``t_min`` and
        at most ``t_max`` s. Returns (the last σ measured, Pa; whether it settled)."""
        s, h = self.sys, self.sys.head
        z_prev = h[H_Z]
        t0 = self.time
        while True:
            self._run(2.0e-3, phase)
            s.take_accumulators()
            self._run(1.0e-3, phase)
            f, _, _, _ = s.take_accumulators()
            sigma = f / self.area
            moved = abs(h[H_Z] - z_prev)
            z_prev = h[H_Z]
            if self.time - t0 > t_min and moved < 0.005 * 2 * self.spec.radius and abs(sigma / stress - 1) < 0.05:
                return sigma, True
            if self.time - t0 > t_max:
                return sigma, False

    def compress(self) -> None:
        """The FT4's compressibility test on the poured bed, as a separate sample: the head, its
        blades retracted (a flat piston, as the FT4's vented piston), comes down onto a copy of
        the poured bed and compresses it through ``procedure.compressibility_stresses`` without
        turning, holding each stress until it has settled (:meth:`hold`, at least
        :data:`~calibrax.core.sheartest.COMPRESSION_MIN_TIME`, at most
        :data:`~calibrax.core.sheartest.COMPRESSION_MAX_TIME`); the bed's height at each is
        recorded. Then the poured bed is put back as it was, so the shear test runs on the bed
        the plain test would (the FT4 tests a fresh sample too)."""
        spec = self.spec
        poured, ceiling = copy.deepcopy(self.sys), self.z_ceiling
        s, h = self.sys, self.sys.head
        p = s.params
        p[P_NBLADES] = 0.0
        top = float(np.max(s.x[:, 2] + s.rad))
        h[H_Z] = top + 0.1 * spec.radius
        self.z_ceiling = h[H_Z] + 10.0 * spec.radius
        h[H_VZ] = h[H_VREF] = 0.0
        h[H_OMEGA] = 0.0
        p[P_USE_HEAD] = 1.0
        bed_mass = float(np.sum(s.mass))
        t_max = COMPRESSION_MAX_TIME
        for stress in spec.procedure.compressibility_stresses:
            h[H_MASS], h[H_DAMP], h[H_TAU_REF] = servo_gains(stress, self.area, spec.radius, self.e_star,
                                                             self.bed_top(), bed_mass)
            self._set_servo(stress, APPROACH_SPEED)
            sigma, settled = self.hold(stress, COMPRESSION_MIN_TIME, t_max, "compressibility test")
            self.compression_height.append(float(h[H_Z]))
            if not settled:
                self.warnings.append(f"compressibility test: the piston was still moving at {stress:.0f} Pa after "
                                     f"{t_max:.3g} s")
            self.log(f"t={self.time:.5f} s compressed at {stress:.0f} Pa: σ = {sigma:.0f} Pa, bed height "
                     f"{h[H_Z] * 1e3:.3f} mm, bulk density {self.bulk():.0f} kg/m³")
        self.sys, self.z_ceiling = poured, ceiling
        self.log(f"t={self.time:.5f} s the poured bed put back for the shear test")

    def insert_blades(self, highest: float) -> None:
        """Take the turning blades into the bed under a low stress
        (:data:`~calibrax.core.sheartest.INSERTION_STRESS_FRACTION` of the preshear's) with the
        friction of the pour on every contact and no rolling resistance, until the head's lower face has come down to ``highest`` (m), the
        top of the poured bed's highest particle; then switch the material's friction back on.
        Without this the blade edges carried the whole preshear stress on the bed's top and never
        went in (see ``calibrax.core.sheartest.INSERTION_STRESS_FRACTION``)."""
        spec, s, h = self.spec, self.sys, self.sys.head
        p = s.params
        # the pour's contact laws on every contact (as LIGGGHTS' pour atom type and YADE's pour table)
        saved = {key: p[key] for key in (P_MU, P_MUR, P_MU_HEAD, P_MUR_HEAD, P_MU_BASE, P_MUR_BASE, P_MU_WALL,
                                         P_MUR_WALL)}
        p[P_MU] = p[P_MU_HEAD] = p[P_MU_BASE] = INSERTION_FRICTION
        p[P_MU_WALL] = min(spec.geometry.wall_friction, INSERTION_FRICTION)
        p[P_MUR] = p[P_MUR_HEAD] = p[P_MUR_BASE] = p[P_MUR_WALL] = 0.0
        self._set_servo(INSERTION_STRESS_FRACTION * spec.procedure.preshear_stress, APPROACH_SPEED)
        t0 = self.time
        t_max = insertion_time_limit(spec, APPROACH_SPEED)
        goal = highest + INSERTION_TOLERANCE_RADII * spec.radius
        while h[H_Z] > goal and self.time - t0 < t_max:
            self._run(1.0e-3, "blade insertion")
        for key, value in saved.items():
            p[key] = value
        self.insertion_gap = float((h[H_Z] - highest) / spec.radius)
        if h[H_Z] > goal:
            self.warnings.append(f"blade insertion: after {t_max:.3g} s the head's face was still "
                                 f"{self.insertion_gap:.2f} particle radii above the poured bed's top: the blades "
                                 "are not fully in the bed")
        self.log(f"t={self.time:.5f} s blades inserted in {self.time - t0:.4f} s: head face at "
                 f"{h[H_Z] * 1e3:.2f} mm, the poured bed's highest particle reached {highest * 1e3:.2f} mm")

    def bulk(self) -> float:
        """Bulk density of the bed under the head, kg/m³: particle mass below the head's face over
        the vessel volume below it."""
        s = self.sys
        zh = s.head[H_Z]
        below = s.x[:, 2] < zh
        return float(np.sum(s.mass[below]) / (math.pi * self.rc**2 * zh))

    def unload_torque(self, max_rotation: float = UNLOAD_MAX_ROTATION) -> float:
        """Relax the bed's residual shear after a rotation, as a shear tester does before it changes
        the normal stress: turn the head back at the rotation rate (under the current σ) until the
        torque, averaged over 0.2 ms, has fallen to zero; at most ``max_rotation`` rad.

        Returns the rotation it took, rad.
        """
        s, h = self.sys, self.sys.head
        rate = self.spec.procedure.rotation_rate
        chunk = max(1, int(round(2.0e-4 / self.dt)))
        phi0 = h[H_PHI]
        h[H_OMEGA] = -rate
        s.take_accumulators()
        while phi0 - h[H_PHI] < max_rotation:
            s.advance(chunk)
            _, torque, _, _ = s.take_accumulators()
            if torque <= 0.0:
                break
        h[H_OMEGA] = 0.0
        self._check("torque unload")
        return float(phi0 - h[H_PHI])

    def settle(self, stress: float) -> None:
        """Unload the residual torque, then hold ``stress`` without rotating for
        ``procedure.settle_time`` so that σ has settled before the rotation restarts."""
        back = self.unload_torque()
        self._set_servo(stress, SHEAR_SPEED_LIMIT)
        self._run(self.spec.procedure.settle_time, "settle")
        s = self.sys
        s.take_accumulators()
        self._run(min(self.spec.numerics.sample_interval, self.spec.procedure.settle_time), "settle")
        f, torque, _, _ = s.take_accumulators()
        self.log(f"t={self.time:.5f} s settled at {stress:.0f} Pa after turning back {back:.4f} rad: "
                 f"σ = {f / self.area:.0f} Pa, τ = "
                 f"{float(shear_stress_from_torque(torque, self.spec.geometry.head_radius)):.0f} Pa")

    def rotate(self, kind: str, stress: float, rotation: float, until_steady: bool = False) -> StepRecord:
        """Rotate the head by ``rotation`` rad at the procedure's rate under ``stress``; record.
        With ``until_steady`` and a capped procedure, go on past ``rotation`` until τ/σ is steady
        (:func:`~calibrax.core.sheartest.preshear_drift` within the procedure's tolerance, checked
        on the schedule of :func:`~calibrax.core.sheartest.steady_schedule`) or the cap."""
        spec, s, h = self.spec, self.sys, self.sys.head
        proc = spec.procedure
        self._set_servo(stress, SHEAR_SPEED_LIMIT)
        rate = proc.rotation_rate
        h[H_OMEGA] = rate
        phi0 = h[H_PHI]
        per = max(1, int(round(spec.numerics.sample_interval / self.dt)))
        nsamples = max(2, int(math.ceil(rotation / rate / (per * self.dt))))
        steady = until_steady and proc.preshear_max_rotation is not None
        if steady:
            first, nsamples, _, every = steady_schedule(proc, rate * per * self.dt)
        rec = np.empty((6, nsamples))
        z_low, z_high = base_layer_bounds(spec)
        s.take_accumulators()
        for k in range(nsamples):
            s.advance(per)
            f, torque, _, _ = s.take_accumulators()
            rec[0, k] = self.time
            rec[1, k] = h[H_PHI] - phi0
            rec[2, k] = float(shear_stress_from_torque(torque, spec.geometry.head_radius))
            rec[3, k] = f / self.area
            rec[4, k] = h[H_Z]
            rec[5, k] = layer_spin(s.x, s.v, z_low, z_high)
            if k % 20 == 0:
                self._check(kind)
            if (steady and k + 1 >= first and (k + 1 - first) % every == 0 and k + 1 < nsamples
                    and preshear_drift(rec[1, :k + 1], rec[2, :k + 1], rec[3, :k + 1], proc.steady_window)
                    <= proc.steady_tolerance):
                rec = rec[:, :k + 1]
                break
        self._check(kind)
        h[H_OMEGA] = 0.0
        step = StepRecord(kind=kind, target_stress=stress, time=rec[0], rotation=rec[1], shear_stress=rec[2],
                          normal_stress=rec[3], bed_height=rec[4], base_spin=rec[5])
        err = float(np.mean(rec[3]) / stress - 1.0)
        self.sigma_errors.append(err)
        self.log(f"t={self.time:.5f} s {kind} at {stress:.0f} Pa: mean σ {np.mean(rec[3]):.0f} Pa "
                 f"({100 * err:+.1f} %), σ sd {np.std(rec[3]):.0f} Pa, τ max {np.max(rec[2]):.0f} Pa, "
                 f"τ end {np.mean(rec[2][-max(1, rec.shape[1] // 5):]):.0f} Pa, head {h[H_Z] * 1e3:.2f} mm, "
                 f"turned {rec[1, -1]:.3f} rad")
        return step

    def run(self) -> None:
        """The whole test."""
        p = self.spec.procedure
        self.pour()
        if p.compressibility_stresses:
            self.compress()
        self.consolidate()
        for k, sigma in enumerate(p.shear_stresses):
            if k > 0:
                self.settle(p.preshear_stress)
            self.steps.append(self.rotate("preshear", p.preshear_stress, p.preshear_rotation, until_steady=True))
            self.bulk_density.append(self.bulk())
            self.settle(sigma)
            self.steps.append(self.rotate("shear", sigma, p.shear_rotation))
        bad = [e for e in self.sigma_errors if abs(e) > 0.05]
        if bad:
            self.warnings.append(f"the servo held σ within 5 % of its target in only "
                                 f"{len(self.sigma_errors) - len(bad)} of {len(self.sigma_errors)} steps "
                                 f"(worst {100 * max(bad, key=abs):+.1f} %)")


def new_logger(path) -> logging.Logger:
    """A logger writing to ``path`` only (no propagation to the root logger)."""
    logger = logging.getLogger(f"calibrax_numba_dem.run.{id(path)}.{time.time_ns()}")
    logger.setLevel(logging.INFO)
    logger.propagate = False
    handler = logging.FileHandler(path, mode="w", encoding="utf-8")
    handler.setFormatter(logging.Formatter("%(message)s"))
    logger.addHandler(handler)
    return logger
