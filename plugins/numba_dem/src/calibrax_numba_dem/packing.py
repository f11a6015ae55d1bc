"""Seeded initial packing: a loose, jittered lattice column inside the vessel that is then poured
(settled under gravity) by the procedure."""

from __future__ import annotations

import math

import numpy as np


def lattice_column(radii: np.ndarray, vessel_radius: float, rng: np.random.Generator,
                   spacing_factor: float = 1.12, jitter: float = 1.0) -> np.ndarray:
    """Positions (N, 3), m, of spheres with radii ``radii`` (N,) stacked in a column on z = 0.

    Spheres sit on a square lattice of pitch a = 2 r_max · ``spacing_factor`` (each layer shifted
    by a random offset, so that the poured bed does not crystallise), inside the vessel radius,
    each moved by a random fraction ``jitter`` of the free gap. Solid fraction ≈ 0.35 before
    pouring (monosized).
    """
    n = radii.size
    r_max = float(radii.max())
    a = 2.0 * r_max * spacing_factor
    free = 0.5 * (a - 2.0 * r_max)
    pts: list[tuple[float, float, float]] = []
    layer = 0
    while len(pts) < n:
        offx, offy = rng.uniform(0.0, a, size=2)
        z = r_max * 1.02 + free + layer * a
        m = int(math.ceil(vessel_radius / a)) + 1
        for iy in range(-m, m + 1):
            for ix in range(-m, m + 1):
                px, py = ix * a + offx, iy * a + offy
                if math.hypot(px, py) <= vessel_radius - r_max * 1.02 - free:
                    pts.append((px, py, z))
        layer += 1
    pos = np.asarray(pts[:n], dtype=float)
    pos += rng.uniform(-jitter * free, jitter * free, size=pos.shape)
    return pos
