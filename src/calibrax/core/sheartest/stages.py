"""Rules of the test's stages that every backend applies the same way, with the values every
backend really uses: the pour, the head's approach, the blades' insertion, how long consolidation may
last, the torque's turn-back before σ changes, and when a particle counts as escaped.

The servo's speed limit while shearing is not here: it belongs to each backend's servo (numba_dem
and LIGGGHTS 1 m/s, high enough never to act; YADE 0.05 m/s for its own head, a rigid body under
the target load)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from calibrax.core.sheartest.spec import ShearCellSpec

#: friction while pouring (DESIGN §3: pour with low friction, then switch to the material's) and
#: while the blades go in
POUR_FRICTION = 0.1
#: gravity multiplier while pouring (speeds up the pour; the bed is consolidated at σ ≫ ρgH after).
#: The bulk density after preshear still remembers the pour, so it is the same on every backend
POUR_GRAVITY = 3.0
#: the pour ends when the fastest particle is slower than this, m/s
POUR_SPEED = 0.02
#: the head's servo speed limit while it comes down, inserts the blades and consolidates, m/s
APPROACH_SPEED = 0.2
#: the fast approach stops with the blade tips this many particle diameters above the bed (and in
#: any case a tenth of a radius above the highest particle: a blade placed into a sphere launches it)
APPROACH_CLEARANCE = 0.5
#: after each rotation the head turns back until its torque has relaxed, at most this far, rad
#: (as ring shear testers do before σ changes)
UNLOAD_MAX_ROTATION = 0.05
#: a particle faster than this, m/s, has escaped or the integration blew up: the run fails
MAX_SPEED = 20.0

#: consolidation may last this many times its minimum (one preshear rotation) before the backends
#: give up waiting for the head to settle (measured durations: docs/explanation/shear-test.md#stage-limits)
CONSOLIDATION_LIMIT_FACTOR = 6.0
#: ... and at least this rotation's time, rad (with the blades in the bed, consolidations take
#: longer than six times a short preshear's minimum)
CONSOLIDATION_LIMIT_ROTATION = 1.0

#: each stress of the compressibility ramp (procedure.compressibility_stresses) is held at least
#: this long, s, and then until the head has stopped sinking, at most COMPRESSION_MAX_TIME, s (the
#: FT4 holds each for 60 s; a DEM bed settles within milliseconds: docs/explanation/shear-test.md#stage-limits)
COMPRESSION_MIN_TIME = 6.0e-3
COMPRESSION_MAX_TIME = 0.05

#: the blades go into the bed under this fraction of the preshear stress, before the bed is
#: consolidated: brought down at the preshear stress, the blades never entered it
#: (docs/explanation/shear-test.md#blades-and-steady-preshear)
INSERTION_STRESS_FRACTION = 0.1
#: particle–particle and particle–head friction while the blades go in (the pour's, numba_dem's
#: POUR_FRICTION); the material's friction is switched on before consolidation (at the material's
#: friction the edges do not cut in: docs/explanation/shear-test.md#stage-limits)
INSERTION_FRICTION = POUR_FRICTION
#: the insertion ends when the head's lower face has come down to within INSERTION_TOLERANCE_RADII
#: particle radii of the top of the poured bed's highest particle (every backend measures that the
#: same way), or after this many times the time the head takes to come down by its blades' height
#: and two particle diameters at the approach speed (then the result warns; :func:`insertion_time_limit`)
INSERTION_TIME_FACTOR = 3.0
INSERTION_TOLERANCE_RADII = 0.1


def insertion_time_limit(spec: "ShearCellSpec", approach_speed: float) -> float:
    """The longest blade insertion, s: :data:`INSERTION_TIME_FACTOR` × (blade height + 2
    particle diameters) / ``approach_speed`` (m/s, the backend's servo speed limit while the head
    comes down), and at least the consolidation's minimum time."""
    travel = spec.geometry.blade_height + 4.0 * spec.radius
    return max(INSERTION_TIME_FACTOR * travel / approach_speed, spec.procedure.consolidation_min_time)
