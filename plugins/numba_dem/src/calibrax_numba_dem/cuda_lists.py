"""The neighbour-list build of numba_dem's CUDA path, on the device: the same lists as the CPU
path's :func:`~calibrax_numba_dem.engine.rebuild`, in the same order, from the same functions.

A build, as on the CPU path (:mod:`neighbours`, :mod:`periodic`):

1. in a sector, every particle that left the wedge is wrapped back (:func:`periodic.wrap_particle`,
   one thread per particle), then each owner's pairs follow (:func:`periodic.wrap_pairs`);
2. the particles within reach of a face get their images (:func:`periodic.sector_images`'s rule),
   counted, scanned and written in the CPU path's order;
3. the particles and images are binned into cells over their bounding box (the CPU path's grid) by
   a counting sort, each cell then sorted by index, so that a cell lists its particles in the CPU
   path's order;
4. each owner's row is counted, the counts scanned into ``start``, and the rows written with their
   history carried over (:func:`neighbours._scan_row`, one thread per owner);
5. the reverse index is counted, scanned and written, each partner's pairs sorted by pair index.

The lists are those of the CPU path, bit for bit, so the pair forces are summed in the same order.
Every sum that sets an order is a scan in one block (fixed order); atomics only count (an order-free
result) or claim slots that are sorted afterwards. The host reads two numbers per build: the
number of cells (to size the cell arrays) and the number of pairs (to enlarge the pair arrays
when they overflow).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import cuda

from .cuda_device import SIMULATOR, device, per_thread
from .layout import P_NBLADES, P_NRIBS, P_SECTOR
from .neighbours import _scan_row, clamp
from .periodic import _face_distance, rotate_xy, sector_count, wrap_pairs, wrap_particle

#: threads of the one-block scans and reductions (a power of two; few under the simulator)
BLOCK_THREADS = 4 if SIMULATOR else 512
#: the CPU path's cap on the cell grid's size along each axis (neighbours.bin_particles)
MAX_DIM = 512


_wrap_particle = device(wrap_particle)
_wrap_pairs = device(wrap_pairs)
_scan_row_d = device(_scan_row)
_face_distance_d = device(_face_distance)
_rotate_xy = device(rotate_xy)
_clamp = device(clamp)
_sector_count = device(sector_count)


@cuda.jit
def wrap_particles_kernel(x, v, w, wid, whist, wrhist, shift, params):
    """Step 1, particles: shift[i] ∈ {−1, 0, 1}, the particle wrapped into the wedge."""
    i = cuda.grid(1)
    if i >= x.shape[0]:
        return
    opening = params[P_SECTOR]
    shift[i] = _wrap_particle(i, x, v, w, wid, whist, wrhist, opening, int(params[P_NBLADES]),
                              int(params[P_NRIBS]), _sector_count(opening), math.cos(opening), math.sin(opening))


@cuda.jit
def wrap_pairs_kernel(start, pj, pimg, hist, rhist, shift, params):
    """Step 1, pairs: owner i's image indices and springs follow the wrap."""
    i = cuda.grid(1)
    if i >= shift.shape[0]:
        return
    opening = params[P_SECTOR]
    _wrap_pairs(i, start, pj, pimg, hist, rhist, shift, math.cos(opening), math.sin(opening))


@cuda.jit
def near_faces_kernel(x, reach, opening, near, count):
    """Step 2: which faces particle i is within ``reach`` of (bits 1: θ = 0, 2: θ = Θ), and how
    many images it needs (none in the full cell)."""
    i = cuda.grid(1)
    if i >= x.shape[0]:
        return
    bits = 0
    if opening > 0.0:
        rho = math.hypot(x[i, 0], x[i, 1])
        theta = math.atan2(x[i, 1], x[i, 0])
        if theta < 0.0:
            theta += 2.0 * math.pi
        if _face_distance_d(rho, theta) < reach:
            bits |= 1
        if _face_distance_d(rho, opening - theta) < reach:
            bits |= 2
    near[i] = bits
    count[i] = (bits & 1) + (bits >> 1)


@cuda.jit
def images_kernel(x, near, offset, opening, xe, orig, eshift):
    """Step 2: entry i is particle i; its images follow the n particles at ``offset[i]``, the one
    across θ = 0 (rotated by +Θ) first, as the CPU path writes them."""
    i = cuda.grid(1)
    n = x.shape[0]
    if i >= n:
        return
    for d in range(3):
        xe[i, d] = x[i, d]
    orig[i] = i
    eshift[i] = 0
    g = n + offset[i]
    c = math.cos(opening)
    s = math.sin(opening)
    for bit in range(1, 3):
        if near[i] & bit:
            k = 1 if bit == 1 else -1
            a, b = _rotate_xy(x[i, 0], x[i, 1], c, k * s)
            xe[g, 0] = a
            xe[g, 1] = b
            xe[g, 2] = x[i, 2]
            orig[g] = i
            eshift[g] = k
            g += 1


@cuda.jit
def bounds_kernel(xe, m, cell_size, lo, dims, meta):
    """Step 3, one block: the bounding box of the m entries and the CPU path's cell grid over it
    (lo, dims); meta[0] = the number of cells."""
    t = cuda.threadIdx.x
    part = cuda.shared.array((BLOCK_THREADS, 6), numba.float64)
    for d in range(3):
        part[t, d] = xe[0, d]
        part[t, 3 + d] = xe[0, d]
    for e in range(t * m // BLOCK_THREADS, (t + 1) * m // BLOCK_THREADS):
        for d in range(3):
            if xe[e, d] < part[t, d]:
                part[t, d] = xe[e, d]
            if xe[e, d] > part[t, 3 + d]:
                part[t, 3 + d] = xe[e, d]
    cuda.syncthreads()
    if t == 0:
        ncell = 1
        for d in range(3):
            mn = part[0, d]
            mx = part[0, 3 + d]
            for k in range(1, BLOCK_THREADS):
                if part[k, d] < mn:
                    mn = part[k, d]
                if part[k, 3 + d] > mx:
                    mx = part[k, 3 + d]
            lo[d] = mn
            dims[d] = _clamp(int(math.floor((mx - mn) / cell_size)) + 1, 1, MAX_DIM)
            ncell *= dims[d]
        meta[0] = ncell


@cuda.jit
def cell_count_kernel(xe, m, lo, dims, cell_size, cell_of, counts):
    """Step 3: entry e's cell, and the cells' occupancies (counted with atomics: an order-free sum)."""
    e = cuda.grid(1)
    if e >= m:
        return
    ix = _clamp(int((xe[e, 0] - lo[0]) / cell_size), 0, dims[0] - 1)
    iy = _clamp(int((xe[e, 1] - lo[1]) / cell_size), 0, dims[1] - 1)
    iz = _clamp(int((xe[e, 2] - lo[2]) / cell_size), 0, dims[2] - 1)
    c = (iz * dims[1] + iy) * dims[0] + ix
    cell_of[e] = c
    cuda.atomic.add(counts, c, 1)


@cuda.jit
def claim_kernel(key, m, start, fill, out):
    """Entry e (< m) takes a free slot of its key's range ``start[key[e]] …`` (out[slot] = e), in
    any order: :func:`sort_ranges_kernel` then orders each range."""
    e = cuda.grid(1)
    if e >= m:
        return
    k = key[e]
    out[start[k] + cuda.atomic.add(fill, k, 1)] = e


@cuda.jit
def sort_ranges_kernel(start, nranges, a):
    """Range r of ``a`` (start[r] … start[r + 1] − 1) sorted ascending, one thread per range (the
    ranges are short: a cell's particles, a partner's pairs)."""
    r = cuda.grid(1)
    if r >= nranges:
        return
    for q in range(start[r] + 1, start[r + 1]):
        value = a[q]
        k = q - 1
        while k >= start[r] and a[k] > value:
            a[k + 1] = a[k]
            k -= 1
        a[k + 1] = value


@cuda.jit
def row_kernel(x, xe, orig, eshift, rad, skin, lo, dims, cell_size, cell_start, order, start_old, pj_old,
               pimg_old, hist_old, rhist_old, start, pj, pimg, hist, rhist, counts, fill):
    """Step 4: owner i's row, counted (``fill`` False: into counts[i]) or written from start[i] on
    with its history carried over (``fill`` True), by the CPU path's own row scan."""
    i = cuda.grid(1)
    if i >= x.shape[0]:
        return
    base = start[i] if fill else 0
    k = _scan_row_d(i, x, xe, orig, eshift, rad, skin, lo, dims, cell_size, cell_start, order, start_old, pj_old,
                    pimg_old, hist_old, rhist_old, base, pj, pimg, hist, rhist, fill)
    if not fill:
        counts[i] = k


@cuda.jit
def scan_kernel(counts, m, out):
    """One block: out[0] = 0, out[k + 1] = counts[0] + … + counts[k] for k < m (a fixed order)."""
    t = cuda.threadIdx.x
    part = cuda.shared.array(BLOCK_THREADS, numba.int64)
    low = t * m // BLOCK_THREADS
    high = (t + 1) * m // BLOCK_THREADS
    acc = 0
    for k in range(low, high):
        acc += counts[k]
    part[t] = acc
    cuda.syncthreads()
    if t == 0:
        total = 0
        for k in range(BLOCK_THREADS):
            here = part[k]
            part[k] = total
            total += here
        out[0] = 0
    cuda.syncthreads()
    acc = part[t]
    for k in range(low, high):
        acc += counts[k]
        out[k + 1] = acc


@cuda.jit
def zero_kernel(a, m):
    """a[:m] = 0."""
    k = cuda.grid(1)
    if k < m:
        a[k] = 0


@cuda.jit
def copy_rows_kernel(src, dst):
    """dst[i, :] = src[i, :] for every row of src (x_build = x)."""
    i = cuda.grid(1)
    if i < src.shape[0]:
        for d in range(src.shape[1]):
            dst[i, d] = src[i, d]


class DeviceLists:
    """The scratch arrays of device list builds for n particles, grown as the bed needs."""

    def __init__(self, n: int, reach: float, cell_size: float, skin: float):
        self.n, self.reach, self.cell_size, self.skin = n, reach, cell_size, skin
        self.shift = cuda.device_array(n, dtype=np.int64)
        self.near = cuda.device_array(n, dtype=np.int64)
        self.count = cuda.device_array(n, dtype=np.int64)
        self.offset = cuda.device_array(n + 1, dtype=np.int64)
        self.xe = cuda.device_array((3 * n, 3))
        self.orig = cuda.device_array(3 * n, dtype=np.int64)
        self.eshift = cuda.device_array(3 * n, dtype=np.int64)
        self.cell_of = cuda.device_array(3 * n, dtype=np.int64)
        self.order = cuda.device_array(3 * n, dtype=np.int64)
        self.lo = cuda.device_array(3)
        self.dims = cuda.device_array(3, dtype=np.int64)
        self.meta = cuda.device_array(1, dtype=np.int64)
        self.cells = 0
        self._grow_cells(1)

    def _grow_cells(self, ncell: int) -> None:
        if ncell + 1 > self.cells:
            self.cells = int(ncell * 1.25) + 16
            self.cell_counts = cuda.device_array(self.cells, dtype=np.int64)
            self.cell_start = cuda.device_array(self.cells + 1, dtype=np.int64)
            self.cell_fill = cuda.device_array(self.cells, dtype=np.int64)

    def build(self, d: dict, params, opening: float) -> int:
        """Rebuild the lists of the device state ``d`` (cuda_engine.CudaDEMSystem's arrays): the new
        lists go into the scratch (start2, pj2, pimg2, hist2, rhist2), whose references are then
        swapped with (start, pj, pimg, hist, rhist); rstart, rpair and x_build are rewritten.
        Returns the pair count; above the capacity ``d["pj"].shape[0]`` only the wrap has been done
        (and ``start2`` written): enlarge the pair arrays and call again."""
        n = self.n
        if opening > 0.0:
            per_thread(wrap_particles_kernel, n)(d["x"], d["v"], d["w"], d["wid"], d["whist"], d["wrhist"],
                                                 self.shift, params)
            per_thread(wrap_pairs_kernel, n)(d["start"], d["pj"], d["pimg"], d["hist"], d["rhist"], self.shift,
                                             params)
        per_thread(near_faces_kernel, n)(d["x"], self.reach, opening, self.near, self.count)
        scan_kernel[1, BLOCK_THREADS](self.count, n, self.offset)
        per_thread(images_kernel, n)(d["x"], self.near, self.offset, opening, self.xe, self.orig, self.eshift)
        images = int(self.offset[n:n + 1].copy_to_host()[0])
        m = n + images
        bounds_kernel[1, BLOCK_THREADS](self.xe, m, self.cell_size, self.lo, self.dims, self.meta)
        ncell = int(self.meta.copy_to_host()[0])
        self._grow_cells(ncell)
        per_thread(zero_kernel, ncell)(self.cell_counts, ncell)
        per_thread(cell_count_kernel, m)(self.xe, m, self.lo, self.dims, self.cell_size, self.cell_of,
                                         self.cell_counts)
        scan_kernel[1, BLOCK_THREADS](self.cell_counts, ncell, self.cell_start)
        per_thread(zero_kernel, ncell)(self.cell_fill, ncell)
        per_thread(claim_kernel, m)(self.cell_of, m, self.cell_start, self.cell_fill, self.order)
        per_thread(sort_ranges_kernel, ncell)(self.cell_start, ncell, self.order)
        row_args = (d["x"], self.xe, self.orig, self.eshift, d["rad"], self.skin, self.lo, self.dims, self.cell_size,
                    self.cell_start, self.order, d["start"], d["pj"], d["pimg"], d["hist"], d["rhist"])
        per_thread(row_kernel, n)(*row_args, d["start2"], d["pj2"], d["pimg2"], d["hist2"], d["rhist2"], self.count,
                                  False)
        scan_kernel[1, BLOCK_THREADS](self.count, n, d["start2"])
        total = int(d["start2"][n:n + 1].copy_to_host()[0])
        if total > d["pj"].shape[0]:
            return total
        per_thread(row_kernel, n)(*row_args, d["start2"], d["pj2"], d["pimg2"], d["hist2"], d["rhist2"], self.count,
                                  True)
        for name in ("start", "pj", "pimg", "hist", "rhist"):
            d[name], d[name + "2"] = d[name + "2"], d[name]
        # the reverse index: pairs counted per partner, scanned, claimed, each partner's sorted
        per_thread(zero_kernel, n)(self.count, n)
        per_thread(_partner_count_kernel, max(total, 1))(d["pj"], total, self.count)
        scan_kernel[1, BLOCK_THREADS](self.count, n, d["rstart"])
        per_thread(zero_kernel, n)(self.near, n)
        per_thread(claim_kernel, max(total, 1))(d["pj"], total, d["rstart"], self.near, d["rpair"])
        per_thread(sort_ranges_kernel, n)(d["rstart"], n, d["rpair"])
        per_thread(copy_rows_kernel, n)(d["x"], d["x_build"])
        return total


@cuda.jit
def _partner_count_kernel(pj, total, counts):
    """Pairs per partner (atomics: an order-free count)."""
    p = cuda.grid(1)
    if p < total:
        cuda.atomic.add(counts, pj[p], 1)
