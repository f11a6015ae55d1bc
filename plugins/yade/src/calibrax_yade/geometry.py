"""The FT4 cell as YADE facets (plugin side, plain numpy).

Conventions are those of the numba_dem backend (``calibrax_numba_dem.geometry``) and the LIGGGHTS
meshes (``calibrax_liggghts.mesh``), so that the three backends simulate the same cell:

* base: the plane z = 0 as one facet covering the vessel (particles' μs, μr by default);
* ribs (optional): ``base_ribs`` vertical radial plates of height ``rib_height`` at angles 2πk/n,
  from the head's hub radius out to the vessel wall (base friction);
* vessel: the lateral wall, a polygonal cylinder of radius D/2 (vertices on the circle),
  friction ``geometry.wall_friction``;
* head, in its own frame: a disc of radius ``head_radius`` at z = 0 (its lower face is the head's
  height z_h) with ``blade_count`` thin radial blades hanging below it from ``hub_radius`` to
  ``head_radius`` down to z = −``blade_height``; blade k lies at angle 2πk/n at rotation 0.

YADE facets are two-sided, so blades and ribs are single plates (two triangles each). All
triangles are returned as arrays of shape (n, 3, 3), m.

The initial packing is the core's (:func:`calibrax.core.sheartest.packing.initial_packing`), shared by all
backends: same spec and seed → the same particles as numba_dem and LIGGGHTS.
"""

from __future__ import annotations

import math

import numpy as np
from calibrax.core.sheartest.facets import radial_plate

__all__ = ["segments_for", "base_mesh", "ribs_mesh", "vessel_mesh", "head_mesh"]


def segments_for(radius: float, particle_radius: float) -> int:
    """Polygon segments so that the chord sag stays below 1 % of a particle radius (48…720)."""
    n = math.ceil(math.pi * math.sqrt(radius / (2.0 * 0.01 * particle_radius)))
    return int(max(48, min(n, 720)))


def _fan_disc(radius: float, z: float, nseg: int, phase: float) -> np.ndarray:
    ang = phase + 2.0 * math.pi * np.arange(nseg + 1) / nseg
    rim = np.stack([radius * np.cos(ang), radius * np.sin(ang), np.full(ang.size, z)], axis=1)
    centre = np.array([0.0, 0.0, z])
    return np.asarray([np.stack([centre, rim[k], rim[k + 1]]) for k in range(nseg)])


def base_mesh(vessel_radius: float, particle_radius: float) -> np.ndarray:
    """The base plane z = 0: one triangle whose inscribed circle is 5 % wider than the vessel.

    A single facet has no inner edges or vertices: on a tessellated plane (a fan disc), a sphere
    near a shared edge or the fan's centre touches several facets at once and is pushed several
    times over. ``particle_radius`` is unused (kept for the mesh functions' common signature).
    """
    rad = 2.0 * 1.05 * vessel_radius  # circumradius = 2 × inradius
    ang = math.pi / 2.0 + 2.0 * math.pi * np.arange(3) / 3.0
    return np.asarray([[[rad * math.cos(a), rad * math.sin(a), 0.0] for a in ang]])


def ribs_mesh(inner_radius: float, vessel_radius: float, count: int, height: float) -> np.ndarray:
    """``count`` radial ribs of height ``height`` on the base, from ``inner_radius`` (the head's hub
    radius, as numba_dem: ribs meeting at the axis wedge a particle among all their edges at once)
    to the wall (empty array when count = 0)."""
    if count <= 0:
        return np.zeros((0, 3, 3))
    return np.concatenate([radial_plate(2.0 * math.pi * k / count, inner_radius, vessel_radius, 0.0, height)
                           for k in range(count)])


def vessel_mesh(vessel_radius: float, z_top: float, particle_radius: float, z_bottom: float = 0.0) -> np.ndarray:
    """The lateral wall: a polygonal cylinder of radius ``vessel_radius`` from ``z_bottom`` to ``z_top``."""
    n = segments_for(vessel_radius, particle_radius)
    ang = 2.0 * math.pi * np.arange(n) / n
    pts = np.stack([vessel_radius * np.cos(ang), vessel_radius * np.sin(ang)], axis=1)
    tris = []
    for k in range(n):
        p, q = pts[k], pts[(k + 1) % n]
        a = [p[0], p[1], z_bottom]
        b = [q[0], q[1], z_bottom]
        c = [q[0], q[1], z_top]
        d = [p[0], p[1], z_top]
        tris.append([a, b, c])
        tris.append([a, c, d])
    return np.asarray(tris, dtype=float)


def head_mesh(head_radius: float, hub_radius: float, blade_count: int, blade_height: float,
              particle_radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The bladed head in its own frame: (disc triangles at z = 0, blade triangles below it)."""
    n = segments_for(head_radius, particle_radius)
    n = blade_count * max(1, math.ceil(n / blade_count))  # fan spokes evenly between the blades
    disc = _fan_disc(head_radius, 0.0, n, math.pi / n)
    blades = np.concatenate([radial_plate(2.0 * math.pi * k / blade_count, hub_radius, head_radius, -blade_height, 0.0)
                             for k in range(blade_count)])
    return disc, blades
