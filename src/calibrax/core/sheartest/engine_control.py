"""The shear test's control of a :class:`~calibrax.core.sheartest.engine_interface.ShearCellEngine`
below the stages: advancing in checked chunks (NaN, escape, blow-up), the servo's load and gains,
holding a stress until the head has settled, the torque's turn-back, and what is read off the bed
(its top, its bulk density under the head). :class:`~calibrax.core.sheartest.stage_runner.StageRunner`
builds the stages on it. SI units: m, s, kg, N, Pa, rad.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from calibrax.core.sheartest.density import bed_top
from calibrax.core.sheartest.engine_interface import ShearCellEngine
from calibrax.core.sheartest.servo import servo_gains
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.core.sheartest.stages import MAX_SPEED, UNLOAD_MAX_ROTATION
from calibrax.errors import SimulationFailed


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


class EngineControl:
    """One :class:`ShearCellSpec` (already validated) on ``engine``, built for it; ``warnings``
    collects the result's warnings, ``sigma_errors`` each rotation's mean σ / target − 1."""

    def __init__(self, spec: ShearCellSpec, engine: ShearCellEngine, log: RunLog):
        self.spec, self.engine, self.log = spec, engine, log
        self.dt = engine.time_step
        self.rc = spec.geometry.vessel_diameter / 2.0
        self.area = math.pi * spec.geometry.head_radius**2
        #: particles above this height, m, have escaped (moves with the head)
        self.z_ceiling = float(engine.positions[:, 2].max()) + 10.0 * spec.radius
        self.warnings: list[str] = []
        self.sigma_errors: list[float] = []

    @property
    def time(self) -> float:
        """Simulated time, s."""
        return self.engine.time

    def check(self, phase: str) -> None:
        """Fail on NaN, a particle out of the cell or faster than MAX_SPEED."""
        e = self.engine
        x, v, rad = e.positions, e.velocities, e.radii
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(v)) and np.isfinite(e.head_height)):
            self.log(f"t={self.time:.5f} s {phase}: NaN in the state")
            raise SimulationFailed(f"NaN in the particle state during {phase}", self.log.tail(), kind="nan")
        vmax = self.max_speed()
        rho = np.sqrt(x[:, 0] ** 2 + x[:, 1] ** 2)
        out = int(np.sum((rho > self.rc + rad) | (x[:, 2] < -rad) | (x[:, 2] > self.z_ceiling)))
        if out:
            self.log(f"t={self.time:.5f} s {phase}: {out} particles left the cell")
            raise SimulationFailed(f"{out} particles escaped the cell during {phase}", self.log.tail(),
                                   kind="unstable")
        if vmax > MAX_SPEED:
            self.log(f"t={self.time:.5f} s {phase}: particle speed {vmax:.3g} m/s")
            raise SimulationFailed(f"blow-up during {phase}: a particle reached {vmax:.3g} m/s",
                                   self.log.tail(), kind="unstable")

    def advance(self, duration: float, phase: str, chunk: float = 1.0e-3) -> None:
        """Advance ``duration`` s (rounded to whole steps) in chunks of ``chunk`` s, checking after each."""
        nsteps = int(round(duration / self.dt))
        per = max(1, int(round(chunk / self.dt)))
        while nsteps > 0:
            k = min(per, nsteps)
            self.engine.advance(k)
            nsteps -= k
            self.check(phase)

    def max_speed(self) -> float:
        """The fastest particle's speed, m/s."""
        return float(np.sqrt(np.max(np.sum(self.engine.velocities**2, axis=1))))

    def bed_top(self) -> float:
        """Height of the bed's surface, m (:func:`calibrax.core.sheartest.bed_top`)."""
        return bed_top(self.engine.positions[:, 2], self.engine.radii)

    def highest(self) -> float:
        """Top of the highest particle, m."""
        return float(np.max(self.engine.positions[:, 2] + self.engine.radii))

    def bulk(self) -> float:
        """Bulk density of the bed under the head, kg/m³: particle mass below the head's face over
        the volume below it of the vessel (or of its sector outside the core)."""
        e = self.engine
        zh = e.head_height
        below = e.positions[:, 2] < zh
        return float(np.sum(e.masses[below]) / (self.spec.bed_cross_section * zh))

    def set_servo(self, stress: float, speed_limit: float) -> None:
        """Servo on ``stress`` Pa over the head's area, at most ``speed_limit`` m/s."""
        self.engine.set_servo(stress * self.area, speed_limit)

    def tune_servo(self, stress: float, bed_height: float) -> tuple[float, float, float]:
        """Set (and return) the servo's gains for ``stress`` Pa on a bed ``bed_height`` m high."""
        gains = servo_gains(stress, self.area, self.spec.radius, self.engine.contact_modulus, bed_height,
                            self.spec.geometry.sector * float(np.sum(self.engine.masses)))
        self.engine.set_servo_gains(*gains)
        return gains

    def hold(self, stress: float, t_min: float, t_max: float, phase: str) -> tuple[float, bool]:
        """Hold ``stress`` (Pa) with the servo until the head has stopped sinking (< 1/200
        diameter in 3 ms) with σ over the last 1 ms within 5 % of it, after at least ``t_min`` and
        at most ``t_max`` s. Returns (the last σ measured, Pa; whether it settled)."""
        e = self.engine
        z_prev = e.head_height
        t0 = self.time
        while True:
            self.advance(2.0e-3, phase)
            e.take_head_load()
            self.advance(1.0e-3, phase)
            f, _ = e.take_head_load()
            sigma = f / self.area
            moved = abs(e.head_height - z_prev)
            z_prev = e.head_height
            if self.time - t0 > t_min and moved < 0.005 * 2 * self.spec.radius and abs(sigma / stress - 1) < 0.05:
                return sigma, True
            if self.time - t0 > t_max:
                return sigma, False

    def unload_torque(self, max_rotation: float = UNLOAD_MAX_ROTATION) -> float:
        """Relax the bed's residual shear after a rotation, as a shear tester does before it changes
        the normal stress: turn the head back at the rotation rate (under the current σ) until the
        torque, averaged over 0.2 ms, has fallen to zero; at most ``max_rotation`` rad.

        Returns the rotation it took, rad.
        """
        e = self.engine
        chunk = max(1, int(round(2.0e-4 / self.dt)))
        phi0 = e.head_angle
        e.set_rotation_rate(-self.spec.procedure.rotation_rate)
        e.take_head_load()
        while phi0 - e.head_angle < max_rotation:
            e.advance(chunk)
            _, torque = e.take_head_load()
            if torque <= 0.0:
                break
        e.set_rotation_rate(0.0)
        self.check("torque unload")
        return float(phi0 - e.head_angle)
