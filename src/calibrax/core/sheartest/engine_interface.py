"""What a DEM engine must offer for :class:`~calibrax.core.sheartest.stage_runner.StageRunner` to run
a shear test's stages on it: a :class:`ShearCellEngine` over the engine's own state.

The engine is built for one spec (its packing, contact laws, cell and head); the runner then only
steps it, moves and loads the head, switches the contact friction between the test's regimes, reads
the head's load and the particles, and copies and restores the state. Everything else (how long,
when a stage is done, what is recorded, the checks) is the runner's, the same for every engine.
SI units throughout: m, s, kg, N, N·m, Pa, rad.
"""

from __future__ import annotations

from typing import Literal, Protocol, runtime_checkable

import numpy as np

#: the contact friction regimes of a test: ``pour`` (POUR_FRICTION on particles, base and head,
#: min(wall, POUR_FRICTION) on the wall, no rolling friction, gravity × POUR_GRAVITY; the state an
#: engine starts in), ``insertion`` (the same at INSERTION_FRICTION, normal gravity), ``material``
#: (the spec's friction on every contact, normal gravity)
FrictionRegime = Literal["pour", "insertion", "material"]


@runtime_checkable
class ShearCellEngine(Protocol):
    """A DEM engine holding one spec's particles in the FT4 cell, with the bladed head.

    Attributes:
        time_step: Δt, s: every stage advances a whole number of steps of it.
        contact_modulus: E* of the contact law, Pa (the servo's gains are tuned on it).
        shear_speed_limit: the head servo's speed limit while settling and shearing, m/s (the
            engine's own: high enough never to act, see stages.py).
    """

    time_step: float
    contact_modulus: float
    shear_speed_limit: float

    @property
    def time(self) -> float:
        """Simulated time since the start, s."""

    @property
    def head_height(self) -> float:
        """Height of the head's lower face (blade tips excluded) above the base, m."""

    @property
    def head_angle(self) -> float:
        """The head's rotation since the start, rad."""

    @property
    def positions(self) -> np.ndarray:
        """Particle centres, shape (N, 3), m (z up from the base, the cell's axis at x = y = 0)."""

    @property
    def velocities(self) -> np.ndarray:
        """Particle velocities, shape (N, 3), m/s."""

    @property
    def radii(self) -> np.ndarray:
        """Particle radii, shape (N,), m."""

    @property
    def masses(self) -> np.ndarray:
        """Particle masses, shape (N,), kg."""

    def advance(self, steps: int) -> None:
        """Advance ``steps`` time steps, accumulating the head's force and torque on every one."""

    def place_head(self, height: float, blades: bool) -> None:
        """Put the head (at rest, in contact with the particles from now on) with its lower face at
        ``height`` m; ``blades`` False retracts them (a flat piston)."""

    def set_servo_gains(self, mass: float, damping: float, tau_ref: float) -> None:
        """The servo's head mass (kg), damping (N·s/m) and v_ref time constant (s)
        (:func:`~calibrax.core.sheartest.servo.servo_gains`)."""

    def set_servo(self, force: float, speed_limit: float) -> None:
        """Let the servo hold a downward load of ``force`` N on the bed, the head moving at most
        ``speed_limit`` m/s."""

    def set_rotation_rate(self, rate: float) -> None:
        """Turn the head at ``rate`` rad/s (negative turns it back; 0 stops it)."""

    def set_friction(self, regime: FrictionRegime) -> None:
        """Switch every contact's friction (and gravity) to ``regime`` (:data:`FrictionRegime`)."""

    def take_head_load(self) -> tuple[float, float]:
        """(mean upward force of the particles on the head, N; mean torque the bed opposes to the
        head's rotation, N·m) over the steps since the last call, which are then forgotten."""

    def snapshot(self) -> object:
        """A copy of the whole state, for :meth:`restore`."""

    def restore(self, snapshot: object) -> None:
        """Put back the state ``snapshot`` copied (once per snapshot)."""
