"""The DEM state and its time integration (velocity Verlet in leapfrog form, as LIGGGHTS'
``nve/sphere``).

:class:`DEMSystem` holds the particle arrays, the contact histories, the head state and the flat
parameter array, and advances them with :func:`advance`, an ``njit`` loop over time steps. Each
step has two parallel passes over particles:

1. :func:`pair_forces`: every pair of the half neighbour lists (:mod:`neighbours`) is computed
   once, by its owner, which sums what it receives from its own pairs into ``fo`` and leaves the
   partner's share (force −F, torque) in a pair-indexed buffer ``pf``;
2. :func:`gather_kick_drift`: every particle adds, in a fixed order, its partner shares, the
   walls and gravity to its own sum, then kicks and drifts itself.

No atomics and no thread-dependent reduction order, so a run is bit-identical for the same input
and *any* thread count.
"""

from __future__ import annotations

import contextlib
import math
import os

import numba
import numpy as np
from numba import njit, prange

from calibrax.core.sheartest.sector import SECTOR_MARGIN_FRACTION

from .contact import clear_history, contact
from .geometry import element_directions, wall_forces
from .layout import (H_ACC_BASE, H_ACC_F, H_ACC_N, H_ACC_T, H_SIZE, H_TIME, P_BETA, P_COH, P_DT,
                     P_ESTAR, P_GSTAR, P_GZ, P_MU, P_MUR, P_NBLADES, P_NRIBS, P_SECTOR, P_SIZE, P_SKIN,
                     W_BASE_F, W_HEAD_F, W_HEAD_T, W_SIZE, WALL_SLOTS)
from .neighbours import build_lists
from .periodic import rotate_xy, wrap_into_sector
from .servo import head_drift, head_kick

def prefer_openmp_threads() -> None:
    """Make Numba pick its OpenMP threading layer first (then TBB, then its workqueue) unless the
    user chose one with ``NUMBA_THREADING_LAYER``.

    Each time step launches two parallel regions; on the quick cell (≈ 1400 particles, ≈ 170 µs a
    step) TBB's per-launch cost ate the whole gain, and 2 threads ran 0.8× as fast as 1, while
    GNU OpenMP gives 1.9× (``benchmarks/dem_throughput.py``). Simulations run in fresh processes
    (fork + exec), so libgomp's fork restriction does not apply to them. Takes effect only before
    the first parallel launch in the process."""
    if os.environ.get("NUMBA_THREADING_LAYER", "default") == "default":
        numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]


prefer_openmp_threads()

STATUS_OK = 0
STATUS_OVERFLOW = 1
#: columns of the pair buffer ``pf``: 0–2 the force on the owner i (N; −F acts on the partner j),
#: 3–5 the torque on the partner j (N·m)
PF_SIZE = 6
#: LLVM fast-math flags of the force kernels: fused multiply-add, reciprocals, signed zeros. Not
#: "nnan"/"ninf" (the NaN checks must keep working) nor reassociation (sums keep their order).
FASTMATH = {"contract", "arcp", "nsz"}
#: the gather pass works on this many blocks of particles (a partition that does not depend on the
#: thread count), whose partial sums are then added in block order
GATHER_BLOCKS = 64


@njit(cache=True, inline="always")
def pair_row(i, x, v, w, rad, mass, start, pj, pimg, hist, rhist, pf, fo, dt, e_star, g_star, beta, mu, mur, coh,
             cs, sn):
    """Contact forces and torques of the pairs particle i owns: the body of :func:`pair_forces`'s
    loop, and of the CUDA path's pair kernel (:mod:`cuda_engine`), so that both paths compute the
    same physics from one source.

    Args:
        i: the owner. x, v, w, rad, mass, start, pj, pimg, hist, rhist, pf, fo: see
            :func:`pair_forces` (pf rows of i's pairs and fo row i are written).
        dt: s. e_star, g_star: Pa. beta: damping factor. mu, mur: sliding and rolling friction.
        coh: SJKR energy density, J/m³. cs, sn: cos Θ and sin Θ of the sector's opening (1, 0 in
            the full cell).
    """
    ri = rad[i]
    mi = mass[i]
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    sfx = 0.0
    sfy = 0.0
    sfz = 0.0
    stx = 0.0
    sty = 0.0
    stz = 0.0
    for p in range(start[i], start[i + 1]):
        j = pj[p]
        # the partner's image, rotated by sΘ (s = 0 in the full cell: a branch it always skips)
        s = pimg[p]
        sj = s * sn
        xj0 = x[j, 0]
        xj1 = x[j, 1]
        vj0 = v[j, 0]
        vj1 = v[j, 1]
        wj0 = w[j, 0]
        wj1 = w[j, 1]
        if s != 0:
            xj0, xj1 = rotate_xy(xj0, xj1, cs, sj)
            vj0, vj1 = rotate_xy(vj0, vj1, cs, sj)
            wj0, wj1 = rotate_xy(wj0, wj1, cs, sj)
        dx = xi0 - xj0
        dy = xi1 - xj1
        dz = xi2 - x[j, 2]
        r2 = dx * dx + dy * dy + dz * dz
        rj = rad[j]
        rsum = ri + rj
        if r2 >= rsum * rsum:
            clear_history(hist, rhist, p)
            for c in range(PF_SIZE):
                pf[p, c] = 0.0
            continue
        rr = math.sqrt(r2)
        inv = 1.0 / rr
        nx = dx * inv
        ny = dy * inv
        nz = dz * inv
        mj = mass[j]
        fx, fy, fz, qx, qy, qz, mx, my, mz, _ = contact(
            nx, ny, nz, rsum - rr, ri * rj / rsum, mi * mj / (mi + mj),
            v[i, 0] - vj0, v[i, 1] - vj1, v[i, 2] - v[j, 2],
            ri * w[i, 0] + rj * wj0, ri * w[i, 1] + rj * wj1, ri * w[i, 2] + rj * w[j, 2],
            w[i, 0] - wj0, w[i, 1] - wj1, w[i, 2] - w[j, 2],
            e_star, g_star, beta, mu, mur, coh, dt, hist, rhist, p)
        sfx += fx
        sfy += fy
        sfz += fz
        stx += mx - ri * qx
        sty += my - ri * qy
        stz += mz - ri * qz
        pfx = fx
        pfy = fy
        tjx = -mx - rj * qx
        tjy = -my - rj * qy
        if s != 0:
            pfx, pfy = rotate_xy(pfx, pfy, cs, -sj)
            tjx, tjy = rotate_xy(tjx, tjy, cs, -sj)
        pf[p, 0] = pfx
        pf[p, 1] = pfy
        pf[p, 2] = fz
        pf[p, 3] = tjx
        pf[p, 4] = tjy
        pf[p, 5] = -mz - rj * qz
    fo[i, 0] = sfx
    fo[i, 1] = sfy
    fo[i, 2] = sfz
    fo[i, 3] = stx
    fo[i, 4] = sty
    fo[i, 5] = stz


@njit(parallel=True, cache=True, fastmath=FASTMATH)
def pair_forces(x, v, w, rad, mass, start, pj, pimg, hist, rhist, params, pf, fo):
    """Contact force and torques of every listed pair, once per pair (:func:`pair_row` per owner).

    Args:
        x, v, w: positions (m), velocities (m/s), angular velocities (rad/s), shape (N, 3).
        rad, mass: shape (N,). start: shape (N + 1,), pj, pimg: shape (P_cap,): the half lists and
            each pair's partner image s (:mod:`periodic`: the owner sees the partner's position,
            velocity and spin rotated by sΘ about the axis, and the partner's share is rotated
            back by −sΘ).
        hist, rhist: pair history, shape (P_cap, 3) (updated; cleared when a pair opens).
        params: see :mod:`layout`.
        pf: out, shape (P_cap, PF_SIZE): the partner's share of each pair (zero for open pairs).
        fo: out, shape (N, 6): force (N) and torque (N·m) on each particle from the pairs it owns,
            summed in list order.
    """
    n = x.shape[0]
    dt = params[P_DT]
    e_star = params[P_ESTAR]
    g_star = params[P_GSTAR]
    beta = params[P_BETA]
    mu = params[P_MU]
    mur = params[P_MUR]
    coh = params[P_COH]
    cs = math.cos(params[P_SECTOR])
    sn = math.sin(params[P_SECTOR])
    for i in prange(n):
        pair_row(i, x, v, w, rad, mass, start, pj, pimg, hist, rhist, pf, fo, dt, e_star, g_star, beta, mu, mur,
                 coh, cs, sn)


@njit(cache=True, inline="always")
def gather_row(i, x, v, w, f, t, rad, mass, inertia, rstart, rpair, pf, fo, params, head, dirs, wid, whist,
               wrhist, x_build, kick, dt, gz):
    """Particle i's total force and torque, then its kick and drift: the body of
    :func:`gather_kick_drift`'s loop, and of the CUDA path's gather kernel (:mod:`cuda_engine`).

    Args: see :func:`gather_kick_drift`; dt: s; gz: gravity along z, m/s².

    Returns:
        (F_head_up N, T_head N·m, F_base_up N, squared displacement since the last build m²): i's
        shares of the head's and the base's loads (:func:`geometry.wall_forces`).
    """
    fx = fo[i, 0]
    fy = fo[i, 1]
    fz = mass[i] * gz + fo[i, 2]
    tx = fo[i, 3]
    ty = fo[i, 4]
    tz = fo[i, 5]
    for q in range(rstart[i], rstart[i + 1]):
        p = rpair[q]
        fx -= pf[p, 0]
        fy -= pf[p, 1]
        fz -= pf[p, 2]
        tx += pf[p, 3]
        ty += pf[p, 4]
        tz += pf[p, 5]
    wfx, wfy, wfz, wtx, wty, wtz, fh, th, fb = wall_forces(i, x, v, w, rad, mass, params, head, dirs,
                                                            wid, whist, wrhist)
    fx += wfx
    fy += wfy
    fz += wfz
    tx += wtx
    ty += wty
    tz += wtz
    f[i, 0] = fx
    f[i, 1] = fy
    f[i, 2] = fz
    t[i, 0] = tx
    t[i, 1] = ty
    t[i, 2] = tz
    a = kick * dt / mass[i]
    b = kick * dt / inertia[i]
    v[i, 0] += a * fx
    v[i, 1] += a * fy
    v[i, 2] += a * fz
    w[i, 0] += b * tx
    w[i, 1] += b * ty
    w[i, 2] += b * tz
    acc = 0.0
    for d in range(3):
        x[i, d] += dt * v[i, d]
        e = x[i, d] - x_build[i, d]
        acc += e * e
    return fh, th, fb, acc


@njit(parallel=True, cache=True, fastmath=FASTMATH)
def gather_kick_drift(x, v, w, f, t, rad, mass, inertia, rstart, rpair, pf, fo, params, head, dirs,
                      wid, whist, wrhist, x_build, kick, part):
    """Total force and torque on every particle, then its kick and drift, block by block
    (:func:`gather_row` per particle).

    Adds, in this order, to gravity the sum over the pairs the particle owns (``fo``), its shares
    of the pairs it is the partner of (``pf``, in increasing pair index) and the walls, into f (N)
    and t (N·m), shape (N, 3); then v += kick·Δt F/m, ω += kick·Δt T/I, x += Δt v (kick = 1, or
    ½ for the leapfrog's first step).

    Args:
        rstart: shape (N + 1,); rpair: shape (P_cap,); pf: shape (P_cap, PF_SIZE); fo: (N, 6).
        dirs: blade and rib directions, see :func:`geometry.element_directions`.
        wid, whist, wrhist: wall-contact slots and histories, see :func:`geometry.wall_forces`.
        x_build: positions at the last list build, shape (N, 3).
        part: out, shape (B, W_SIZE + 1): per block of particles (B blocks, a fixed partition
            whatever the thread count), the sums of the upward force on the head (N), the head's
            resisting torque (N·m) and the base's upward force (N) in columns W_HEAD_F, W_HEAD_T,
            W_BASE_F, and the largest squared displacement since the last list build (m²) in
            column W_SIZE.
    """
    dt = params[P_DT]
    gz = params[P_GZ]
    n = x.shape[0]
    nb = part.shape[0]
    for c in prange(nb):
        fh_sum = 0.0
        th_sum = 0.0
        fb_sum = 0.0
        d2max = 0.0
        for i in range(c * n // nb, (c + 1) * n // nb):
            fh, th, fb, acc = gather_row(i, x, v, w, f, t, rad, mass, inertia, rstart, rpair, pf, fo, params, head,
                                         dirs, wid, whist, wrhist, x_build, kick, dt, gz)
            fh_sum += fh
            th_sum += th
            fb_sum += fb
            d2max = max(d2max, acc)
        part[c, W_HEAD_F] = fh_sum
        part[c, W_HEAD_T] = th_sum
        part[c, W_BASE_F] = fb_sum
        part[c, W_SIZE] = d2max


@njit(cache=True)
def max_displacement2(x, x_build):
    """Largest squared displacement of a particle since the last list build, m²; shapes (N, 3)."""
    m = 0.0
    for i in range(x.shape[0]):
        m = max(m, (x[i, 0] - x_build[i, 0]) ** 2 + (x[i, 1] - x_build[i, 1]) ** 2 + (x[i, 2] - x_build[i, 2]) ** 2)
    return m


@njit(cache=True)
def rebuild(x, v, w, rad, skin, cell_size, params, start, pj, pimg, hist, rhist, rstart, rpair, start2, pj2, pimg2,
            hist2, rhist2, x_build, wid, whist, wrhist):
    """In a sector, bring every particle that left the wedge back into it (:mod:`periodic`); then
    rebuild the half lists (scratch: start2, pj2, pimg2, hist2, rhist2), copy them into (start, pj,
    pimg, hist, rhist), record x_build. Returns the pair count; above the capacity ``pj.shape[0]``
    nothing but the wrap changed and the caller must enlarge the pair arrays."""
    opening = params[P_SECTOR]
    if opening > 0.0:
        wrap_into_sector(x, v, w, start, pj, pimg, hist, rhist, wid, whist, wrhist, opening, int(params[P_NBLADES]),
                         int(params[P_NRIBS]))
    total = build_lists(x, rad, skin, cell_size, opening, start, pj, pimg, hist, rhist, start2, pj2, pimg2, hist2,
                        rhist2, rstart, rpair)
    if total > pj.shape[0]:
        return total
    start[:] = start2
    pj[:total] = pj2[:total]
    pimg[:total] = pimg2[:total]
    hist[:total] = hist2[:total]
    rhist[:total] = rhist2[:total]
    x_build[:, :] = x
    return total


@njit(cache=True, inline="always")
def finish_step(head, fh, th, fb, dt):
    """The head's part of a step, once the particles have moved: the servo's kick and the head's
    drift under the particles' upward force ``fh`` (N), and the load accumulators (``fh``, the
    resisting torque ``th`` N·m, the base's force ``fb`` N) and the clock advanced by ``dt`` s.
    Shared with the CUDA path's head kernel (:mod:`cuda_engine`)."""
    head_kick(head, fh, dt)
    head_drift(head, dt)
    head[H_ACC_F] += fh
    head[H_ACC_T] += th
    head[H_ACC_BASE] += fb
    head[H_ACC_N] += 1.0
    head[H_TIME] += dt


@njit(cache=True)
def advance(nsteps, kick0, x, v, w, f, t, rad, mass, inertia, x_build,
            start, pj, pimg, hist, rhist, rstart, rpair, pf, start2, pj2, pimg2, hist2, rhist2,
            cell_size, params, head, wid, whist, wrhist):
    """Advance ``nsteps`` steps: per step, rebuild the lists if a particle moved more than half
    the skin since the last build, compute every force at the current positions, kick (the first
    step by ``kick0`` Δt, then Δt) and drift the particles, then the head.

    Returns (status, steps done, list builds, pair count). Status ``STATUS_OVERFLOW`` means the
    pair arrays overflowed before the step was taken; the caller enlarges them and calls again.
    (start2, pj2, pimg2, hist2, rhist2) are scratch buffers for the rebuild.
    """
    dt = params[P_DT]
    skin = params[P_SKIN]
    n = x.shape[0]
    dirs = np.zeros((max(1, int(params[P_NBLADES]) + int(params[P_NRIBS])), 2))
    fo = np.empty((n, 6))
    part = np.empty((min(GATHER_BLOCKS, max(1, n)), W_SIZE + 1))
    builds = 0
    lim = 0.25 * skin * skin
    dmax = max_displacement2(x, x_build)
    kick = kick0
    for step in range(nsteps):
        if dmax > lim:
            total = rebuild(x, v, w, rad, skin, cell_size, params, start, pj, pimg, hist, rhist, rstart, rpair, start2,
                            pj2, pimg2, hist2, rhist2, x_build, wid, whist, wrhist)
            if total > pj.shape[0]:
                return STATUS_OVERFLOW, step, builds, total
            builds += 1
        element_directions(params, head, dirs)
        pair_forces(x, v, w, rad, mass, start, pj, pimg, hist, rhist, params, pf, fo)
        gather_kick_drift(x, v, w, f, t, rad, mass, inertia, rstart, rpair, pf, fo, params, head, dirs,
                          wid, whist, wrhist, x_build, kick, part)
        kick = 1.0
        fh = 0.0
        th = 0.0
        fb = 0.0
        dmax = 0.0
        for c in range(part.shape[0]):
            fh += part[c, W_HEAD_F]
            th += part[c, W_HEAD_T]
            fb += part[c, W_BASE_F]
            dmax = max(dmax, part[c, W_SIZE])
        finish_step(head, fh, th, fb, dt)
    return STATUS_OK, nsteps, builds, start[n]


class DEMSystem:
    """Spheres in the analytic FT4 cell, ready to advance.

    Attributes (SI): x, v, w (N, 3) positions, velocities, angular velocities (v, ω half a step
    behind x once stepping has started, as in leapfrog); f, t (N, 3) the forces and torques of the
    last step; rad, mass, inertia (N,); params (P_SIZE,), head (H_SIZE,) — see :mod:`layout`.
    Contacts: the half lists (start (N + 1,), pj (P_cap,), see :mod:`neighbours`) with the pair
    history hist, rhist (P_cap, 3) (m, N·m) and reverse index (rstart, rpair), each pair's partner
    image pimg (P_cap,) in a periodic sector (:mod:`periodic`); wall slots wid
    (N, WALL_SLOTS) with their history whist, wrhist (N · WALL_SLOTS, 3).
    """

    def __init__(self, x: np.ndarray, rad: np.ndarray, density: float, params: np.ndarray,
                 head: np.ndarray | None = None, v: np.ndarray | None = None, pair_capacity: int = 0):
        n = x.shape[0]
        self.x = np.ascontiguousarray(x, dtype=np.float64)
        self.rad = np.ascontiguousarray(rad, dtype=np.float64)
        self.mass = 4.0 / 3.0 * math.pi * self.rad**3 * density
        self.inertia = 0.4 * self.mass * self.rad**2
        self.v = np.zeros((n, 3)) if v is None else np.ascontiguousarray(v, dtype=np.float64)
        self.w = np.zeros((n, 3))
        self.f = np.zeros((n, 3))
        self.t = np.zeros((n, 3))
        assert params.shape == (P_SIZE,)
        self.params = params
        self.head = np.zeros(H_SIZE) if head is None else head
        r_max, r_min = float(self.rad.max()), float(self.rad.min())
        if self.params[P_SKIN] <= 0:
            # the sector's core keeps a particle's own image out of its neighbour list at this skin
            self.params[P_SKIN] = SECTOR_MARGIN_FRACTION * r_min
        self.cell_size = 2.0 * r_max + self.params[P_SKIN]
        ratio = r_max / r_min
        self.wid = -np.ones((n, WALL_SLOTS), dtype=np.int64)
        self.whist = np.zeros((n * WALL_SLOTS, 3))
        self.wrhist = np.zeros((n * WALL_SLOTS, 3))
        self.start = np.zeros(n + 1, dtype=np.int64)
        self.rstart = np.zeros(n + 1, dtype=np.int64)
        self.start2 = np.zeros(n + 1, dtype=np.int64)
        self._alloc_pairs(pair_capacity or int(n * (8 + 6 * ratio**2)) + 16)
        self.x_build = self.x + 1e9  # forces a build at the first step
        self.list_builds = 0
        self._started = False

    def _alloc_pairs(self, capacity: int) -> None:
        """(Re)allocate the pair arrays with room for ``capacity`` pairs, keeping the current lists."""
        keep = int(self.start[-1]) if hasattr(self, "pj") else 0
        old = (self.pj, self.pimg, self.hist, self.rhist, self.rpair) if keep else None
        self.pj = np.zeros(capacity, dtype=np.int64)
        # int8: an image index is −1, 0 or 1, and the pair pass reads one per pair
        self.pimg = np.zeros(capacity, dtype=np.int8)
        self.hist = np.zeros((capacity, 3))
        self.rhist = np.zeros((capacity, 3))
        self.rpair = np.zeros(capacity, dtype=np.int64)
        if old is not None:
            for new, prev in zip((self.pj, self.pimg, self.hist, self.rhist, self.rpair), old):
                new[:keep] = prev[:keep]
        self.pf = np.zeros((capacity, PF_SIZE))
        self.pj2 = np.zeros_like(self.pj)
        self.pimg2 = np.zeros_like(self.pimg)
        self.hist2 = np.zeros_like(self.hist)
        self.rhist2 = np.zeros_like(self.rhist)

    @property
    def n(self) -> int:
        """Particle count."""
        return self.x.shape[0]

    def read(self, name: str) -> np.ndarray:
        """State array ``name`` (``"x"``, ``"v"``, …) to read, not to change (the CUDA path's
        :meth:`~calibrax_numba_dem.cuda_engine.CudaDEMSystem.read` then need not send it back)."""
        return getattr(self, name)

    @property
    def pair_count(self) -> int:
        """Pairs in the current half neighbour lists."""
        return int(self.start[-1])

    def advance(self, nsteps: int) -> None:
        """Advance ``nsteps`` time steps (enlarging the pair arrays when they overflow)."""
        done = 0
        while done < nsteps:
            status, k, builds, total = advance(
                nsteps - done, 1.0 if self._started else 0.5, self.x, self.v, self.w, self.f, self.t, self.rad,
                self.mass, self.inertia, self.x_build, self.start, self.pj, self.pimg, self.hist, self.rhist,
                self.rstart, self.rpair, self.pf, self.start2, self.pj2, self.pimg2, self.hist2, self.rhist2,
                self.cell_size,
                self.params, self.head, self.wid, self.whist, self.wrhist)
            done += k
            self._started = self._started or k > 0
            self.list_builds += builds
            if status == STATUS_OVERFLOW:
                self._alloc_pairs(int(total * 1.5) + 64)

    def rebuild_lists(self) -> int:
        """Rebuild the neighbour lists now (wrapping a sector's particles first), as
        :meth:`advance` does when a particle has moved half the skin; returns the pair count
        (above the capacity nothing but the wrap changed)."""
        return int(rebuild(self.x, self.v, self.w, self.rad, self.params[P_SKIN], self.cell_size, self.params,
                           self.start, self.pj, self.pimg, self.hist, self.rhist, self.rstart, self.rpair,
                           self.start2, self.pj2, self.pimg2, self.hist2, self.rhist2, self.x_build, self.wid,
                           self.whist, self.wrhist))

    def take_accumulators(self) -> tuple[float, float, float, int]:
        """(mean upward force on the head N, mean resisting torque N·m, mean base force N, steps)
        since the last call; resets them."""
        h = self.head
        nacc = int(h[H_ACC_N])
        if nacc == 0:
            return float("nan"), float("nan"), float("nan"), 0
        out = (h[H_ACC_F] / nacc, h[H_ACC_T] / nacc, h[H_ACC_BASE] / nacc, nacc)
        h[H_ACC_F] = h[H_ACC_T] = h[H_ACC_BASE] = h[H_ACC_N] = 0.0
        return out

    def kinetic_energy(self) -> float:
        """Translational + rotational kinetic energy, J."""
        return float(0.5 * np.sum(self.mass * np.sum(self.v**2, axis=1))
                     + 0.5 * np.sum(self.inertia * np.sum(self.w**2, axis=1)))


@contextlib.contextmanager
def numba_threads(n: int):
    """Run the enclosed block with ``n`` Numba threads (restored afterwards)."""
    old = numba.get_num_threads()
    numba.set_num_threads(max(1, min(n, numba.config.NUMBA_NUM_THREADS)))
    try:
        yield
    finally:
        numba.set_num_threads(old)


def make_system(device: str, x: np.ndarray, rad: np.ndarray, density: float, params: np.ndarray,
                **options) -> "DEMSystem":
    """A :class:`DEMSystem` (``device`` "cpu") or a :class:`~calibrax_numba_dem.cuda_engine.CudaDEMSystem`
    ("cuda", imported only then), built with the same arguments."""
    if device == "cuda":
        from .cuda_engine import CudaDEMSystem

        return CudaDEMSystem(x, rad, density, params, **options)
    return DEMSystem(x, rad, density, params, **options)


def make_params(**values: float) -> np.ndarray:
    """A params array (see :mod:`layout`) from keyword names of its P_* constants, lower-case
    without the prefix, e.g. ``make_params(dt=1e-6, gz=-9.81, estar=...)``."""
    from . import layout

    p = np.zeros(P_SIZE)
    for key, value in values.items():
        p[getattr(layout, "P_" + key.upper())] = value
    return p
