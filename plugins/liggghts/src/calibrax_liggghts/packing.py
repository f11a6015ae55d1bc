"""The seeded initial state of the fill, identical to numba_dem's for the same spec and seed
(``calibrax_numba_dem.procedure.ShearTestDriver`` and ``packing.lattice_column``): radii drawn from
the size distribution, shuffled, stacked as a loose jittered lattice column, small random
velocities. Copied rather than imported, so that this backend does not depend on numba_dem."""

from __future__ import annotations

import math

import numpy as np
from calibrax.core.sheartest import ShearCellSpec


def lattice_column(radii: np.ndarray, vessel_radius: float, rng: np.random.Generator,
                   spacing_factor: float = 1.04, jitter: float = 0.1) -> np.ndarray:
    """Positions (N, 3), m, of spheres with radii ``radii`` (N,) stacked in a column on z = 0:
    square lattice of pitch a = 2 r_max · ``spacing_factor``, alternate layers shifted by a/2,
    inside the vessel, each moved by a random fraction ``jitter`` of the free gap."""
    n = radii.size
    r_max = float(radii.max())
    a = 2.0 * r_max * spacing_factor
    free = 0.5 * (a - 2.0 * r_max)
    pts: list[tuple[float, float, float]] = []
    layer = 0
    while len(pts) < n:
        off = 0.5 * a * (layer % 2)
        z = r_max * 1.02 + layer * a
        m = int(math.ceil(vessel_radius / a)) + 1
        for iy in range(-m, m + 1):
            for ix in range(-m, m + 1):
                px, py = ix * a + off, iy * a + off
                if math.hypot(px, py) <= vessel_radius - r_max * 1.02 - free:
                    pts.append((px, py, z))
        layer += 1
    pos = np.asarray(pts[:n], dtype=float)
    pos += rng.uniform(-jitter * free, jitter * free, size=pos.shape)
    return pos


def initial_state(spec: ShearCellSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(positions (N, 3) m, radii (N,) m, velocities (N, 3) m/s) before the pour."""
    rng = np.random.default_rng(spec.numerics.seed)
    n = spec.particle_count
    radii = spec.size_distribution.sample(spec.radius, n, rng)
    radii = radii[rng.permutation(n)]
    x = lattice_column(radii, spec.geometry.vessel_diameter / 2.0, rng)
    v = rng.normal(0.0, 0.05, size=x.shape)
    return x, radii, v
