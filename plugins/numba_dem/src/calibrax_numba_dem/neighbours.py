"""Cell-list neighbour search producing full (both-direction) Verlet lists with a skin.

Each particle i owns the row ``nbr[i, :ncnt[i]]`` of the particles j ≠ i closer than
r_i + r_j + skin, in a deterministic order (cell by cell, then by index). When a list is rebuilt,
the tangential and rolling history of each directed pair (i, j) is carried over to its new slot.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


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


@njit(cache=True)
def _cell_index(px, py, pz, lo, dims, cell_size):
    ix = min(max(int((px - lo[0]) / cell_size), 0), dims[0] - 1)
    iy = min(max(int((py - lo[1]) / cell_size), 0), dims[1] - 1)
    iz = min(max(int((pz - lo[2]) / cell_size), 0), dims[2] - 1)
    return (iz * dims[1] + iy) * dims[0] + ix


@njit(parallel=True, cache=True)
def build_lists(x, rad, skin, cell_size, nbr_old, ncnt_old, hist_old, rhist_old,
                nbr, ncnt, hist, rhist):
    """Fill ``nbr``/``ncnt`` (shape (N, maxn), (N,)) and carry history over from the old lists.

    Returns the largest neighbour count found; if it exceeds ``nbr.shape[1]`` the lists are
    incomplete and the caller must enlarge them and call again.
    """
    n = x.shape[0]
    maxn = nbr.shape[1]
    lo, dims, cell_start, order = bin_particles(x, cell_size)
    counts = np.zeros(n, dtype=np.int64)
    for i in prange(n):
        px = x[i, 0]
        py = x[i, 1]
        pz = x[i, 2]
        ix = min(max(int((px - lo[0]) / cell_size), 0), dims[0] - 1)
        iy = min(max(int((py - lo[1]) / cell_size), 0), dims[1] - 1)
        iz = min(max(int((pz - lo[2]) / cell_size), 0), dims[2] - 1)
        k = 0
        for cz in range(max(iz - 1, 0), min(iz + 2, dims[2])):
            for cy in range(max(iy - 1, 0), min(iy + 2, dims[1])):
                for cx in range(max(ix - 1, 0), min(ix + 2, dims[0])):
                    c = (cz * dims[1] + cy) * dims[0] + cx
                    for q in range(cell_start[c], cell_start[c + 1]):
                        j = order[q]
                        if j == i:
                            continue
                        dx = px - x[j, 0]
                        dy = py - x[j, 1]
                        dz = pz - x[j, 2]
                        cut = rad[i] + rad[j] + skin
                        if dx * dx + dy * dy + dz * dz < cut * cut:
                            if k < maxn:
                                nbr[i, k] = j
                                # carry the history of the directed pair (i, j) over
                                found = -1
                                for ko in range(ncnt_old[i]):
                                    if nbr_old[i, ko] == j:
                                        found = ko
                                        break
                                for d in range(3):
                                    if found >= 0:
                                        hist[i, k, d] = hist_old[i, found, d]
                                        rhist[i, k, d] = rhist_old[i, found, d]
                                    else:
                                        hist[i, k, d] = 0.0
                                        rhist[i, k, d] = 0.0
                            k += 1
        ncnt[i] = min(k, maxn)
        counts[i] = k
    return counts.max()
