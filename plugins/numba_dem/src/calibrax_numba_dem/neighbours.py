"""Cell-list neighbour search producing half Verlet lists with a skin, in compressed rows.

Every pair {i, j} closer than r_i + r_j + skin is listed once, by its *owner* (:func:`owns`: the
lower index when i + j is even, the higher one when it is odd, so that every particle owns about
half of its neighbours whatever its index, and the rows stay balanced between threads). Owner i's
pairs are ``p = start[i] … start[i + 1] − 1`` with partner ``pj[p]``, in a deterministic order
(cell by cell, then by position in the cell). The pair's normal points from j to i, and its
tangential and rolling history (rows ``p`` of two arrays of shape (P, 3)) is carried over to its
new slot when the lists are rebuilt (the owner of a pair never changes).

In a periodic sector (:mod:`periodic`) a pair may join i to an image of j across a face: it stores
the image ``pimg[p]`` (s ∈ {−1, 0, 1}: the partner seen at R(sΘ) x_j), and its history is carried
over only to the same partner and image.

The reverse index lists, for each particle j, the pairs it is the partner of:
``rpair[rstart[j] … rstart[j + 1] − 1]``, in increasing p, so that a particle can sum the forces of
all its pairs in a fixed order (bit-identical results for any thread count).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .periodic import sector_images


@njit(cache=True, inline="always")
def owns(i, j):
    """Whether particle i owns the pair {i, j} (i ≠ j)."""
    return (i < j) == ((i + j) % 2 == 0)


@njit(cache=True)
def bin_particles(x, cell_size):
    """Counting sort of particles into a cell grid over their bounding box.

    Args:
        x: positions, shape (N, 3), m. cell_size: edge of a cubic cell, m (≥ 2 r_max + skin).

    Returns:
        (lo (3,), dims (3,) int64, cell_start (ncell + 1,), order (N,)): particles of cell c are
        ``order[cell_start[c]:cell_start[c + 1]]``.
    """
    n = x.shape[0]
    lo = np.empty(3)
    dims = np.empty(3, dtype=np.int64)
    for d in range(3):
        mn = x[0, d]
        mx = x[0, d]
        for i in range(n):
            if x[i, d] < mn:
                mn = x[i, d]
            if x[i, d] > mx:
                mx = x[i, d]
        lo[d] = mn
        dims[d] = min(max(1, int(math.floor((mx - mn) / cell_size)) + 1), 512)
    ncell = dims[0] * dims[1] * dims[2]
    cell_of = np.empty(n, dtype=np.int64)
    counts = np.zeros(ncell + 1, dtype=np.int64)
    for i in range(n):
        c = _cell_index(x[i, 0], x[i, 1], x[i, 2], lo, dims, cell_size)
        cell_of[i] = c
        counts[c + 1] += 1
    for c in range(ncell):
        counts[c + 1] += counts[c]
    fill = counts[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = cell_of[i]
        order[fill[c]] = i
        fill[c] += 1
    return lo, dims, counts, order


@njit(cache=True, inline="always")
def clamp(k, low, high):
    """The integer k limited to [low, high] (a conditional, not min/max: the CUDA path compiles the
    list build's functions too, see calibrax_numba_dem.cuda_engine.compile_ptx)."""
    if k < low:
        return low
    if k > high:
        return high
    return k


@njit(cache=True, inline="always")
def _cell_index(px, py, pz, lo, dims, cell_size):
    ix = clamp(int((px - lo[0]) / cell_size), 0, dims[0] - 1)
    iy = clamp(int((py - lo[1]) / cell_size), 0, dims[1] - 1)
    iz = clamp(int((pz - lo[2]) / cell_size), 0, dims[2] - 1)
    return (iz * dims[1] + iy) * dims[0] + ix


@njit(cache=True, inline="always")
def _scan_row(i, x, xe, orig, shift, rad, skin, lo, dims, cell_size, cell_start, order, start_old, pj_old,
              pimg_old, hist_old, rhist_old, base, pj, pimg, hist, rhist, fill):
    """Pairs owned by i within the cut-off, among the particles and images ``xe`` (binned: ``order``
    indexes it; entry q is particle orig[q] seen through image shift[q]). With ``fill`` False only
    counts them; with ``fill`` True writes them from row ``base`` on (partner, image, carried-over
    history). Returns the count."""
    px = x[i, 0]
    py = x[i, 1]
    pz = x[i, 2]
    ri = rad[i] + skin
    ix = clamp(int((px - lo[0]) / cell_size), 0, dims[0] - 1)
    iy = clamp(int((py - lo[1]) / cell_size), 0, dims[1] - 1)
    iz = clamp(int((pz - lo[2]) / cell_size), 0, dims[2] - 1)
    k = 0
    for cz in range(clamp(iz - 1, 0, iz), clamp(iz + 2, iz, dims[2])):
        for cy in range(clamp(iy - 1, 0, iy), clamp(iy + 2, iy, dims[1])):
            for cx in range(clamp(ix - 1, 0, ix), clamp(ix + 2, ix, dims[0])):
                c = (cz * dims[1] + cy) * dims[0] + cx
                for q in range(cell_start[c], cell_start[c + 1]):
                    e = order[q]
                    j = orig[e]
                    if j == i or not owns(i, j):
                        continue
                    dx = px - xe[e, 0]
                    dy = py - xe[e, 1]
                    dz = pz - xe[e, 2]
                    cut = ri + rad[j]
                    if dx * dx + dy * dy + dz * dz >= cut * cut:
                        continue
                    if fill:
                        p = base + k
                        pj[p] = j
                        pimg[p] = shift[e]
                        found = -1
                        for po in range(start_old[i], start_old[i + 1]):
                            if pj_old[po] == j and pimg_old[po] == shift[e]:
                                found = po
                                break
                        for d in range(3):
                            if found >= 0:
                                hist[p, d] = hist_old[found, d]
                                rhist[p, d] = rhist_old[found, d]
                            else:
                                hist[p, d] = 0.0
                                rhist[p, d] = 0.0
                    k += 1
    return k


@njit(parallel=True, cache=True)
def build_lists(x, rad, skin, cell_size, opening, start_old, pj_old, pimg_old, hist_old, rhist_old,
                start, pj, pimg, hist, rhist, rstart, rpair):
    """Build the half lists into (start, pj, pimg, hist, rhist) and the reverse index (rstart,
    rpair), carrying the history over from the old lists (start_old, pj_old, pimg_old, hist_old,
    rhist_old).

    Args:
        x: positions, shape (N, 3), m (inside the sector's wedge when ``opening`` > 0).
        rad: radii, shape (N,), m. skin, cell_size: m. opening: the sector's Θ, rad (0: full cell).
        start_old, start, rstart: shape (N + 1,). pj_old, pimg_old, pj, pimg, rpair: shape (P_cap,).
        hist_old, rhist_old, hist, rhist: shape (P_cap, 3).

    Returns:
        The number of pairs found. If it exceeds the capacity ``pj.shape[0]`` nothing but
        ``start`` was written and the caller must enlarge the pair arrays and call again.
    """
    n = x.shape[0]
    xe, orig, shift = sector_images(x, 2.0 * np.max(rad) + skin, opening)
    lo, dims, cell_start, order = bin_particles(xe, cell_size)
    counts = np.empty(n, dtype=np.int64)
    for i in prange(n):
        counts[i] = _scan_row(i, x, xe, orig, shift, rad, skin, lo, dims, cell_size, cell_start, order, start_old,
                              pj_old, pimg_old, hist_old, rhist_old, 0, pj, pimg, hist, rhist, False)
    start[0] = 0
    for i in range(n):
        start[i + 1] = start[i] + counts[i]
    total = start[n]
    if total > pj.shape[0]:
        return total
    for i in prange(n):
        _scan_row(i, x, xe, orig, shift, rad, skin, lo, dims, cell_size, cell_start, order, start_old, pj_old,
                  pimg_old, hist_old, rhist_old, start[i], pj, pimg, hist, rhist, True)
    reverse_index(start, pj, rstart, rpair)
    return total


@njit(cache=True)
def reverse_index(start, pj, rstart, rpair):
    """Counting sort of the pairs by partner: ``rpair[rstart[j]:rstart[j + 1]]`` are the pairs
    whose partner is j, in increasing pair index. Shapes: start, rstart (N + 1,); pj, rpair (P,)."""
    n = start.shape[0] - 1
    total = start[n]
    rstart[:] = 0
    for p in range(total):
        rstart[pj[p] + 1] += 1
    for j in range(n):
        rstart[j + 1] += rstart[j]
    fill = rstart[:-1].copy()
    for p in range(total):
        j = pj[p]
        rpair[fill[j]] = p
        fill[j] += 1
