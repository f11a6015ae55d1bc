"""The periodic sector's kernels: the wedge 0 ≤ θ < Θ = 2π/k of the cell with rotationally periodic
faces (:mod:`calibrax.core.sheartest.sector`).

* :func:`wrap_into_sector`, at each neighbour-list build: a particle that has left the wedge
  through one face is rotated by ∓Θ back into it, with its velocity, spin and wall-contact
  history; its wall contacts move to the image element (blade b → b ∓ n_b/k), and its pairs keep
  their history: the partner's image index of each pair is shifted to match, and an owner's
  spring vectors are rotated with it.
* :func:`sector_images`: the particles within a contact's reach of a face, copied rotated by ±Θ
  across the other face, so that the cell-list search (:mod:`neighbours`) finds the pairs that
  cross a face. A pair then stores its partner's image s ∈ {−1, 0, 1}: the owner sees the
  partner at R(sΘ) x_j, with velocity R(sΘ) v_j and spin R(sΘ) ω_j
  (:func:`calibrax_numba_dem.engine.pair_forces`).

Vectors are rotated about the z axis: R(φ)(a, b, c) = (a cos φ − b sin φ, a sin φ + b cos φ, c).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry import EID_BLADE0, EID_RIB0
from .layout import WALL_SLOTS


@njit(cache=True, inline="always")
def rotate_xy(a, b, c, s):
    """(a, b) rotated by the angle whose cosine and sine are (c, s)."""
    return c * a - s * b, s * a + c * b


@njit(cache=True)
def wrap_shift(px, py, opening):
    """0 if (px, py) lies in the wedge 0 ≤ θ < ``opening``; else −1 (it left through the face at
    θ = opening: rotate it by −Θ) or +1 (it left through θ = 0: rotate it by +Θ)."""
    theta = math.atan2(py, px)
    if theta < 0.0:
        theta += 2.0 * math.pi
    if theta < opening:
        return 0
    return -1 if theta - opening < 2.0 * math.pi - theta else 1


@njit(cache=True, inline="always")
def _rotate_rows(a, row, c, s):
    a[row, 0], a[row, 1] = rotate_xy(a[row, 0], a[row, 1], c, s)


@njit(cache=True)
def _image_element(eid, w, nblades, nribs, sector):
    """The wall element a particle rotated by w·Θ touches instead of ``eid``."""
    if nblades > 0 and EID_BLADE0 <= eid < EID_BLADE0 + nblades:
        return EID_BLADE0 + (eid - EID_BLADE0 + w * (nblades // sector)) % nblades
    if nribs > 0 and EID_RIB0 <= eid < EID_RIB0 + nribs:
        return EID_RIB0 + (eid - EID_RIB0 + w * (nribs // sector)) % nribs
    return eid


@njit(cache=True, inline="always")
def wrap_particle(i, x, v, w, wid, whist, wrhist, opening, nblades, nribs, sector, c, s):
    """Rotate particle i back into the wedge if it has left it, with its velocity, spin, wall slots
    and their history (the per-particle part of :func:`wrap_into_sector`, shared with the CUDA
    path's list build). c, s: cos Θ, sin Θ. Returns its shift k ∈ {−1, 0, 1} (:func:`wrap_shift`)."""
    k = wrap_shift(x[i, 0], x[i, 1], opening)
    if k == 0:
        return 0
    sk = k * s
    _rotate_rows(x, i, c, sk)
    _rotate_rows(v, i, c, sk)
    _rotate_rows(w, i, c, sk)
    for slot in range(WALL_SLOTS):
        if wid[i, slot] >= 0:
            wid[i, slot] = _image_element(wid[i, slot], k, nblades, nribs, sector)
            _rotate_rows(whist, i * WALL_SLOTS + slot, c, sk)
            _rotate_rows(wrhist, i * WALL_SLOTS + slot, c, sk)
    return k


@njit(cache=True, inline="always")
def wrap_pairs(i, start, pj, pimg, hist, rhist, shift, c, s):
    """The pairs owner i holds after a wrap: each partner image index shifted to match, and i's
    spring vectors turned with i (the per-owner part of :func:`wrap_into_sector`)."""
    for p in range(start[i], start[i + 1]):
        pimg[p] += shift[i] - shift[pj[p]]
        if shift[i] != 0:
            _rotate_rows(hist, p, c, shift[i] * s)
            _rotate_rows(rhist, p, c, shift[i] * s)


@njit(cache=True)
def wrap_into_sector(x, v, w, start, pj, pimg, hist, rhist, wid, whist, wrhist, opening, nblades, nribs):
    """Rotate every particle that has left the wedge back into it (see the module's docstring).

    Args:
        x, v, w: positions (m), velocities (m/s), spins (rad/s), shape (N, 3), updated.
        start, pj, pimg: the current half lists (N + 1,), (P_cap,), (P_cap,); pimg updated.
        hist, rhist: pair spring history (P_cap, 3), updated for the pairs a wrapped particle owns.
        wid, whist, wrhist: wall slots (N, WALL_SLOTS) and their history (N·WALL_SLOTS, 3).
        opening: Θ, rad. nblades, nribs: the head's blades (0 when retracted) and the base's ribs.

    Returns:
        The number of particles wrapped.
    """
    n = x.shape[0]
    sector = sector_count(opening)
    shift = np.zeros(n, dtype=np.int64)
    c = math.cos(opening)
    s = math.sin(opening)
    wrapped = 0
    for i in range(n):
        shift[i] = wrap_particle(i, x, v, w, wid, whist, wrhist, opening, nblades, nribs, sector, c, s)
        if shift[i] != 0:
            wrapped += 1
    if wrapped == 0:
        return 0
    for i in range(n):
        wrap_pairs(i, start, pj, pimg, hist, rhist, shift, c, s)
    return wrapped


@njit(cache=True, inline="always")
def sector_count(opening):
    """k of a sector of opening Θ = 2π/k (rounded to the nearest integer)."""
    return int(2.0 * math.pi / opening + 0.5)


@njit(cache=True)
def _face_distance(rho, angle):
    """Distance, m, of a point at radius ``rho`` to a face ray at angle ``angle`` (rad) from it."""
    return rho * math.sin(angle) if angle < 0.5 * math.pi else rho


@njit(cache=True)
def sector_images(x, reach, opening):
    """The particles and their images across the faces, for the neighbour search.

    Args:
        x: positions inside the wedge, shape (N, 3), m. reach: the largest pair cut-off, m.
        opening: Θ, rad (0: the full cell, no images).

    Returns:
        (xe (N + G, 3), orig (N + G,), shift (N + G,)): the N particles, then G images; image g is
        particle orig[g] rotated by shift[g]·Θ (+1 for those within ``reach`` of the face θ = 0,
        −1 for those within it of θ = Θ).
    """
    n = x.shape[0]
    if opening <= 0.0:
        return x, np.arange(n), np.zeros(n, dtype=np.int64)
    near = np.zeros(n, dtype=np.int64)
    count = 0
    for i in range(n):
        rho = math.hypot(x[i, 0], x[i, 1])
        theta = math.atan2(x[i, 1], x[i, 0])
        if theta < 0.0:
            theta += 2.0 * math.pi
        if _face_distance(rho, theta) < reach:
            near[i] |= 1
            count += 1
        if _face_distance(rho, opening - theta) < reach:
            near[i] |= 2
            count += 1
    xe = np.empty((n + count, 3))
    orig = np.empty(n + count, dtype=np.int64)
    shift = np.zeros(n + count, dtype=np.int64)
    xe[:n] = x
    for i in range(n):
        orig[i] = i
    g = n
    c = math.cos(opening)
    s = math.sin(opening)
    for i in range(n):
        for bit, k in ((1, 1), (2, -1)):
            if near[i] & bit:
                xe[g, 0], xe[g, 1] = rotate_xy(x[i, 0], x[i, 1], c, k * s)
                xe[g, 2] = x[i, 2]
                orig[g] = i
                shift[g] = k
                g += 1
    return xe, orig, shift
