"""The seeded initial state of the fill, shared by every backend so that the same spec and seed
start from the same particles on numba_dem, LIGGGHTS and YADE: radii drawn from the size
distribution, shuffled, stacked as a loose jittered lattice column inside the vessel, with small
random velocities. Each backend then pours it (settles it under gravity) with its own engine.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from calibrax.core.sheartest.spec import ShearCellSpec

#: Standard deviation of each initial velocity component, m/s.
INITIAL_SPEED_SD = 0.1


class InitialPacking(NamedTuple):
    """Particles before the pour: ``radii`` (N,) m, ``positions`` (N, 3) m, ``velocities`` (N, 3) m/s."""

    radii: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray


def lattice_column(radii: np.ndarray, vessel_radius: float, rng: np.random.Generator,
                   spacing_factor: float = 1.12, jitter: float = 1.0, sector: int = 1, core: float = 0.0) -> np.ndarray:
    """Positions (N, 3), m, of spheres with radii ``radii`` (N,) stacked in a column on z = 0.

    Spheres sit on a square lattice of pitch a = 2 r_max · ``spacing_factor`` (each layer shifted
    by a random offset, so that the poured bed does not crystallise), inside ``vessel_radius``,
    each moved by a random fraction ``jitter`` of the free gap. Solid fraction ≈ 0.35 before
    pouring (monosized). No sphere overlaps the base; see :func:`initial_packing` for the wall.
    Only the ring outside a core of radius ``core`` (m) is filled, and with ``sector`` k > 1 only
    the wedge 0 ≤ θ < 2π/k of it, each sphere half a pitch and its jitter from both faces, so that
    no sphere overlaps another's periodic image.
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
                rho = math.hypot(px, py)
                if rho <= vessel_radius - r_max * 1.02 - free and (core == 0.0 or rho >= core + r_max * 1.02 + free) \
                        and (sector == 1 or _inside_sector(px, py, sector, 0.5 * a + 1.5 * free)):
                    pts.append((px, py, z))
        layer += 1
    pos = np.asarray(pts[:n], dtype=float)
    pos += rng.uniform(-jitter * free, jitter * free, size=pos.shape)
    return pos


def _inside_sector(px: float, py: float, sector: int, margin: float) -> bool:
    """Whether (px, py), m, lies in the wedge 0 ≤ θ < 2π/``sector``, at least ``margin`` (m) from
    both faces."""
    theta = math.atan2(py, px) % (2.0 * math.pi)
    rho = math.hypot(px, py)
    opening = 2.0 * math.pi / sector
    if theta >= opening:
        return False
    to_face = [rho * math.sin(d) if d < 0.5 * math.pi else rho for d in (theta, opening - theta)]
    return min(to_face) >= margin


def initial_packing(spec: ShearCellSpec) -> InitialPacking:
    """The particles of ``spec`` before the pour, drawn from ``spec.numerics.seed``.

    The jitter can push an outer sphere a few per cent of its radius into the vessel wall (or a
    sector's core); a Hertz overlap that deep launches it, so such spheres are moved radially back. With
    base ribs the whole column is lifted by the rib height, so that no sphere starts in a rib.
    """
    rng = np.random.default_rng(spec.numerics.seed)
    n = spec.particle_count
    radii = spec.size_distribution.sample(spec.radius, n, rng)
    radii = radii[rng.permutation(n)]
    vessel_radius = spec.geometry.vessel_diameter / 2.0
    sector, core = spec.geometry.sector, spec.core_radius
    x = lattice_column(radii, vessel_radius, rng, sector=sector, core=core)
    v = rng.normal(0.0, INITIAL_SPEED_SD, size=x.shape)
    rho = np.hypot(x[:, 0], x[:, 1])
    limit = vessel_radius - 1.001 * radii
    scale = np.where(rho > limit, limit / np.maximum(rho, 1e-300), 1.0)
    if core > 0.0:
        inner = core + 1.001 * radii
        scale = np.where(rho < inner, inner / np.maximum(rho, 1e-300), scale)
    x[:, :2] *= scale[:, None]
    x[:, 2] = np.maximum(x[:, 2], 1.001 * radii)
    if spec.geometry.base_ribs > 0:
        # the column starts on the ribs' tops: a sphere placed across a rib (a plate of no
        # thickness) would start almost a radius deep in it and be launched (NaN in the pour)
        x[:, 2] += spec.geometry.rib_height
    return InitialPacking(radii, x, v)
