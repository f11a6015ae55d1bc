"""numba_dem as a :class:`~calibrax.core.sheartest.engine_interface.ShearCellEngine`: the spec's
packing in a :class:`DEMSystem`, its head and contact parameters set through the flat arrays of
:mod:`layout`. The shear test's stages are run on it by core's
:class:`~calibrax.core.sheartest.stage_runner.StageRunner`."""

from __future__ import annotations

import copy

from calibrax.core.sheartest import GRAVITY, INSERTION_FRICTION, POUR_FRICTION, POUR_GRAVITY, ShearCellSpec
from calibrax.core.sheartest.packing import initial_packing
from calibrax.core.sheartest.sector import sector_angle

from .contact import beta_from_restitution, effective_moduli
from .engine import DEMSystem, make_params, make_system
from .layout import (H_DAMP, H_FTARGET, H_MASS, H_MODE, H_OMEGA, H_PHI, H_TAU_REF, H_TIME, H_VMAX, H_VREF, H_VZ,
                     H_Z, P_GZ, P_MU, P_MU_BASE, P_MU_HEAD, P_MU_WALL, P_MUR, P_MUR_BASE, P_MUR_HEAD, P_MUR_WALL,
                     P_NBLADES, P_USE_HEAD)

#: servo speed limit while settling and shearing, m/s: high enough never to act, because a limit
#: that clips the head's response to contact spikes rectifies them and biases σ upwards (the pour,
#: approach, insertion and escape constants are every backend's: calibrax.core.sheartest.stages)
SHEAR_SPEED_LIMIT = 1.0


class NumbaShearEngine:
    """One spec's bed in numba_dem, poured from :func:`initial_packing` in the ``pour`` regime.

    In a periodic sector of 1/k of the cell (``geometry.sector``, :mod:`periodic`) the engine holds
    the sector's particles and its share of the head: the servo's load, mass and damping are 1/k of
    the whole head's, and the load it reports is k times the sector's, the whole head's."""

    shear_speed_limit = SHEAR_SPEED_LIMIT

    def __init__(self, spec: ShearCellSpec):
        g, m = spec.geometry, spec.material
        self.time_step = spec.time_step
        self.contact_modulus, g_star = effective_moduli(m.youngs_modulus, m.poisson_ratio)
        mu_b, mur_b = spec.effective_base_friction()
        mu_head, mur = spec.effective_head_friction(), m.rolling_friction
        #: P_* slot → value of each friction regime (engine_interface.FrictionRegime)
        self.regimes = {
            "pour": self._friction(-GRAVITY * POUR_GRAVITY, POUR_FRICTION, 0.0, POUR_FRICTION, 0.0,
                                   min(g.wall_friction, POUR_FRICTION), 0.0, mu_head, mur),
            "insertion": self._friction(-GRAVITY, INSERTION_FRICTION, 0.0, INSERTION_FRICTION, 0.0,
                                        min(g.wall_friction, INSERTION_FRICTION), 0.0, INSERTION_FRICTION, 0.0),
            "material": self._friction(-GRAVITY, m.sliding_friction, mur, mu_b, mur_b, g.wall_friction,
                                       spec.effective_wall_rolling_friction(), mu_head, mur)}
        radii, x, v = initial_packing(spec)
        params = make_params(
            dt=self.time_step, estar=self.contact_modulus, gstar=g_star, beta=beta_from_restitution(m.restitution),
            coh=spec.sjkr_energy_density(), use_cyl=1.0, rc=g.vessel_diameter / 2.0, use_base=1.0,
            nribs=g.base_ribs, rib_h=g.rib_height, use_head=0.0, head_r=g.head_radius, hub_r=g.hub_radius,
            blade_h=g.blade_height, nblades=g.blade_count,
            sector=sector_angle(g.sector) if g.sector > 1 else 0.0, core_r=spec.core_radius)
        self.blade_count = float(g.blade_count)
        self.sector = float(g.sector)
        self.sys = make_system(spec.numerics.device, x, radii, m.density, params, v=v)
        self.set_friction("pour")

    @staticmethod
    def _friction(gz, mu, mur, mu_base, mur_base, mu_wall, mur_wall, mu_head, mur_head) -> dict[int, float]:
        return {P_GZ: gz, P_MU: mu, P_MUR: mur, P_MU_BASE: mu_base, P_MUR_BASE: mur_base, P_MU_WALL: mu_wall,
                P_MUR_WALL: mur_wall, P_MU_HEAD: mu_head, P_MUR_HEAD: mur_head}

    time = property(lambda self: float(self.sys.head[H_TIME]))
    head_height = property(lambda self: float(self.sys.head[H_Z]))
    head_angle = property(lambda self: float(self.sys.head[H_PHI]))
    # read only: the stage runner never writes them, and on the CUDA path a read need not go back up
    positions = property(lambda self: self.sys.read("x"))
    velocities = property(lambda self: self.sys.read("v"))
    radii = property(lambda self: self.sys.rad)
    masses = property(lambda self: self.sys.mass)

    def advance(self, steps: int) -> None:
        self.sys.advance(steps)

    def place_head(self, height: float, blades: bool) -> None:
        h, p = self.sys.head, self.sys.params
        h[H_Z], h[H_VZ], h[H_VREF] = height, 0.0, 0.0
        p[P_USE_HEAD], p[P_NBLADES] = 1.0, self.blade_count if blades else 0.0

    def set_servo_gains(self, mass: float, damping: float, tau_ref: float) -> None:
        h = self.sys.head
        h[H_MASS], h[H_DAMP], h[H_TAU_REF] = mass / self.sector, damping / self.sector, tau_ref

    def set_servo(self, force: float, speed_limit: float) -> None:
        h = self.sys.head
        h[H_MODE], h[H_FTARGET], h[H_VMAX] = 1.0, force / self.sector, speed_limit

    def set_rotation_rate(self, rate: float) -> None:
        self.sys.head[H_OMEGA] = rate

    def set_friction(self, regime: str) -> None:
        for slot, value in self.regimes[regime].items():
            self.sys.params[slot] = value

    def take_head_load(self) -> tuple[float, float]:
        f, torque, _, _ = self.sys.take_accumulators()
        return self.sector * f, self.sector * torque

    def snapshot(self) -> DEMSystem:
        return copy.deepcopy(self.sys)

    def restore(self, snapshot: DEMSystem) -> None:
        self.sys = snapshot
