"""Triangles of the cell's flat parts, for the backends that build their walls from facets
(LIGGGHTS' meshes, YADE's facets)."""

from __future__ import annotations

import math

import numpy as np


def radial_plate(angle: float, s0: float, s1: float, z0: float, z1: float) -> np.ndarray:
    """Two triangles of the vertical radial plate {s e_angle + z e_z : s ∈ [s0, s1], z ∈ [z0, z1]}
    (a blade or a rib), shape (2, 3, 3): triangle, vertex, xyz in m. ``angle`` in rad."""
    c, s = math.cos(angle), math.sin(angle)
    a = np.array([s0 * c, s0 * s, z0])
    b = np.array([s1 * c, s1 * s, z0])
    d = np.array([s1 * c, s1 * s, z1])
    e = np.array([s0 * c, s0 * s, z1])
    return np.asarray([[a, b, d], [a, d, e]])


__all__ = ["radial_plate"]
