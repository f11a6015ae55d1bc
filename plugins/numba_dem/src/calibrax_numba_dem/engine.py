"""The DEM state and its time integration (velocity Verlet, as LIGGGHTS' ``nve/sphere``).

:class:`DEMSystem` holds the particle arrays, the contact histories, the head state and the flat
parameter array, and advances them with :func:`advance`, an ``njit`` loop over time steps whose
force pass runs in parallel over particles. Each particle sums its own forces from a full
neighbour list (no atomics), so a run is bit-identical for the same input and any thread count.
"""

from __future__ import annotations

import contextlib
import math

import numba
import numpy as np
from numba import njit, prange

from .geometry import wall_forces
from .layout import (H_ACC_BASE, H_ACC_F, H_ACC_N, H_ACC_T, H_SIZE, H_TIME, P_BETA, P_COH, P_DT,
                     P_ESTAR, P_GSTAR, P_GZ, P_MU, P_MUR, P_SIZE, P_SKIN, W_BASE_F, W_HEAD_F,
                     W_HEAD_T, W_SIZE, WALL_SLOTS)
from .neighbours import build_lists
from .contact import clear_history, contact
from .servo import head_drift, head_kick

STATUS_OK = 0
STATUS_OVERFLOW = 1


@njit(parallel=True, cache=True)
def force_pass(x, v, w, rad, mass, nbr, ncnt, hist, rhist, params, head, wid, whist, wrhist,
               f, t, wf):
    """Forces f (N) and torques t (N·m) on every particle, shape (N, 3), from particles, walls
    and gravity; per-particle wall reactions into wf, shape (N, W_SIZE)."""
    n = x.shape[0]
    dt = params[P_DT]
    e_star = params[P_ESTAR]
    g_star = params[P_GSTAR]
    beta = params[P_BETA]
    mu = params[P_MU]
    mur = params[P_MUR]
    coh = params[P_COH]
    gz = params[P_GZ]
    for i in prange(n):
        fx = 0.0
        fy = 0.0
        fz = mass[i] * gz
        tx = 0.0
        ty = 0.0
        tz = 0.0
        ri = rad[i]
        for k in range(ncnt[i]):
            j = nbr[i, k]
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            dz = x[i, 2] - x[j, 2]
            r2 = dx * dx + dy * dy + dz * dz
            rj = rad[j]
            rsum = ri + rj
            if r2 >= rsum * rsum:
                if hist[i, k, 0] != 0.0 or hist[i, k, 1] != 0.0 or hist[i, k, 2] != 0.0 \
                        or rhist[i, k, 0] != 0.0 or rhist[i, k, 1] != 0.0 or rhist[i, k, 2] != 0.0:
                    clear_history(hist, rhist, i, k)
                continue
            rr = math.sqrt(r2)
            nx = dx / rr
            ny = dy / rr
            nz = dz / rr
            reff = ri * rj / rsum
            meff = mass[i] * mass[j] / (mass[i] + mass[j])
            cfx, cfy, cfz, ctx, cty, ctz, fn = contact(
                nx, ny, nz, rsum - rr, reff, meff, ri,
                v[i, 0] - v[j, 0], v[i, 1] - v[j, 1], v[i, 2] - v[j, 2],
                ri * w[i, 0] + rj * w[j, 0], ri * w[i, 1] + rj * w[j, 1], ri * w[i, 2] + rj * w[j, 2],
                w[i, 0] - w[j, 0], w[i, 1] - w[j, 1], w[i, 2] - w[j, 2],
                e_star, g_star, beta, mu, mur, coh, dt, hist, rhist, i, k)
            fx += cfx
            fy += cfy
            fz += cfz
            tx += ctx
            ty += cty
            tz += ctz
        wfx, wfy, wfz, wtx, wty, wtz, fh, th, fb = wall_forces(i, x, v, w, rad, mass, params, head,
                                                                wid, whist, wrhist)
        f[i, 0] = fx + wfx
        f[i, 1] = fy + wfy
        f[i, 2] = fz + wfz
        t[i, 0] = tx + wtx
        t[i, 1] = ty + wty
        t[i, 2] = tz + wtz
        wf[i, W_HEAD_F] = fh
        wf[i, W_HEAD_T] = th
        wf[i, W_BASE_F] = fb


@njit(parallel=True, cache=True)
def kick_drift(x, v, w, f, t, mass, inertia, x_build, dt, d2):
    """Leapfrog form of velocity Verlet: v += Δt F/m, ω += Δt T/I, x += Δt v; d2[i] = squared
    displacement since the last neighbour-list build (m²). v and ω are half-step values, the ones
    the force pass sees (as in LIGGGHTS)."""
    for i in prange(x.shape[0]):
        a = dt / mass[i]
        b = dt / inertia[i]
        acc = 0.0
        for d in range(3):
            v[i, d] += a * f[i, d]
            w[i, d] += b * t[i, d]
            x[i, d] += dt * v[i, d]
            e = x[i, d] - x_build[i, d]
            acc += e * e
        d2[i] = acc


@njit(parallel=True, cache=True)
def max_displacement2(x, x0):
    """Largest squared displacement since the last list build, m²."""
    n = x.shape[0]
    d2 = np.empty(n)
    for i in prange(n):
        a = x[i, 0] - x0[i, 0]
        b = x[i, 1] - x0[i, 1]
        c = x[i, 2] - x0[i, 2]
        d2[i] = a * a + b * b + c * c
    m = 0.0
    for i in range(n):
        if d2[i] > m:
            m = d2[i]
    return m


@njit(cache=True)
def advance(nsteps, x, v, w, f, t, rad, mass, inertia, nbr, ncnt, hist, rhist, x_build,
            nbr2, ncnt2, hist2, rhist2, cell_size, params, head, wid, whist, wrhist, wf):
    """Advance ``nsteps`` velocity-Verlet steps. Returns (status, steps done, list builds).

    Status ``STATUS_OVERFLOW`` means a neighbour list overflowed before the step was taken; the
    caller enlarges the lists and calls again. (nbr2, hist2, …) are scratch buffers for the
    rebuild; the current lists are always in (nbr, hist, …).
    """
    dt = params[P_DT]
    skin = params[P_SKIN]
    builds = 0
    n = x.shape[0]
    d2 = np.empty(n)
    for i in range(n):
        d2[i] = (x[i, 0] - x_build[i, 0]) ** 2 + (x[i, 1] - x_build[i, 1]) ** 2 + (x[i, 2] - x_build[i, 2]) ** 2
    lim = 0.25 * skin * skin
    for step in range(nsteps):
        # list check on the positions of this step's start (d2 from the previous drift)
        dmax = 0.0
        for i in range(n):
            if d2[i] > dmax:
                dmax = d2[i]
        if dmax > lim:
            top = build_lists(x, rad, skin, cell_size, nbr, ncnt, hist, rhist, nbr2, ncnt2, hist2, rhist2)
            if top > nbr.shape[1]:
                return STATUS_OVERFLOW, step, builds, top
            nbr[:, :] = nbr2
            ncnt[:] = ncnt2
            hist[:, :, :] = hist2
            rhist[:, :, :] = rhist2
            x_build[:, :] = x
            d2[:] = 0.0
            builds += 1
        kick_drift(x, v, w, f, t, mass, inertia, x_build, dt, d2)
        head_drift(head, dt)
        force_pass(x, v, w, rad, mass, nbr, ncnt, hist, rhist, params, head, wid, whist, wrhist, f, t, wf)
        fh = 0.0
        th = 0.0
        fb = 0.0
        for i in range(n):
            fh += wf[i, W_HEAD_F]
            th += wf[i, W_HEAD_T]
            fb += wf[i, W_BASE_F]
        head_kick(head, fh, dt)
        head[H_ACC_F] += fh
        head[H_ACC_T] += th
        head[H_ACC_BASE] += fb
        head[H_ACC_N] += 1.0
        head[H_TIME] += dt
    return STATUS_OK, nsteps, builds, 0


class DEMSystem:
    """Spheres in the analytic FT4 cell, ready to advance.

    Attributes (SI): x, v, w (N, 3) positions, velocities, angular velocities; f, t (N, 3) forces
    and torques; rad, mass, inertia (N,); params (P_SIZE,), head (H_SIZE,) — see :mod:`layout`.
    """

    def __init__(self, x: np.ndarray, rad: np.ndarray, density: float, params: np.ndarray,
                 head: np.ndarray | None = None, v: np.ndarray | None = None, maxn: int = 0):
        n = x.shape[0]
        self.x = np.ascontiguousarray(x, dtype=np.float64)
        self.rad = np.ascontiguousarray(rad, dtype=np.float64)
        self.mass = 4.0 / 3.0 * math.pi * self.rad**3 * density
        self.inertia = 0.4 * self.mass * self.rad**2
        self.v = np.zeros((n, 3)) if v is None else np.ascontiguousarray(v, dtype=np.float64)
        self.w = np.zeros((n, 3))
        self.f = np.zeros((n, 3))
        self.t = np.zeros((n, 3))
        self.wf = np.zeros((n, W_SIZE))
        assert params.shape == (P_SIZE,)
        self.params = params
        self.head = np.zeros(H_SIZE) if head is None else head
        r_max, r_min = float(self.rad.max()), float(self.rad.min())
        if self.params[P_SKIN] <= 0:
            self.params[P_SKIN] = 0.3 * r_min
        self.cell_size = 2.0 * r_max + self.params[P_SKIN]
        ratio = r_max / r_min
        self.maxn = maxn or int(min(n, 20 + 12 * ratio**2))
        self.wid = -np.ones((n, WALL_SLOTS), dtype=np.int64)
        self.whist = np.zeros((n, WALL_SLOTS, 3))
        self.wrhist = np.zeros((n, WALL_SLOTS, 3))
        self._alloc_lists(self.maxn)
        self.x_build = self.x + 1e9  # forces a build at the first step
        self.list_builds = 0
        self._forces_valid = False

    def _alloc_lists(self, maxn: int, keep: bool = False) -> None:
        n = self.x.shape[0]
        nbr = np.zeros((n, maxn), dtype=np.int64)
        hist = np.zeros((n, maxn, 3))
        rhist = np.zeros((n, maxn, 3))
        ncnt = np.zeros(n, dtype=np.int64)
        if keep:
            m = self.nbr.shape[1]
            nbr[:, :m] = self.nbr
            hist[:, :m] = self.hist
            rhist[:, :m] = self.rhist
            ncnt[:] = self.ncnt
        self.nbr, self.hist, self.rhist, self.ncnt = nbr, hist, rhist, ncnt
        self.nbr2 = np.zeros_like(nbr)
        self.hist2 = np.zeros_like(hist)
        self.rhist2 = np.zeros_like(rhist)
        self.ncnt2 = np.zeros_like(ncnt)
        self.maxn = maxn

    @property
    def n(self) -> int:
        """Particle count."""
        return self.x.shape[0]

    def compute_forces(self) -> None:
        """Evaluate forces at the current state (needed once before the first step)."""
        if max_displacement2(self.x, self.x_build) > 0.25 * self.params[P_SKIN] ** 2:
            self._rebuild()
        force_pass(self.x, self.v, self.w, self.rad, self.mass, self.nbr, self.ncnt, self.hist, self.rhist,
                   self.params, self.head, self.wid, self.whist, self.wrhist, self.f, self.t, self.wf)
        # leapfrog start: v(−Δt/2) so that the first full kick lands on v(0) + ½Δt F/m
        h = 0.5 * self.params[P_DT]
        self.v -= h * self.f / self.mass[:, None]
        self.w -= h * self.t / self.inertia[:, None]
        self._forces_valid = True

    def _rebuild(self) -> None:
        while True:
            top = build_lists(self.x, self.rad, self.params[P_SKIN], self.cell_size, self.nbr, self.ncnt,
                              self.hist, self.rhist, self.nbr2, self.ncnt2, self.hist2, self.rhist2)
            if top <= self.maxn:
                break
            self._alloc_lists(int(top * 1.5) + 4, keep=True)
        self.nbr[:] = self.nbr2
        self.ncnt[:] = self.ncnt2
        self.hist[:] = self.hist2
        self.rhist[:] = self.rhist2
        self.x_build[:] = self.x
        self.list_builds += 1

    def advance(self, nsteps: int) -> None:
        """Advance ``nsteps`` time steps (enlarging the neighbour lists when they overflow)."""
        if not self._forces_valid:
            self.compute_forces()
        done = 0
        while done < nsteps:
            status, k, builds, top = advance(
                nsteps - done, self.x, self.v, self.w, self.f, self.t, self.rad, self.mass, self.inertia,
                self.nbr, self.ncnt, self.hist, self.rhist, self.x_build, self.nbr2, self.ncnt2, self.hist2,
                self.rhist2, self.cell_size, self.params, self.head, self.wid, self.whist, self.wrhist, self.wf)
            done += k
            self.list_builds += builds
            if status == STATUS_OVERFLOW:
                self._alloc_lists(int(top * 1.5) + 4, keep=True)

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


def make_params(**values: float) -> np.ndarray:
    """A params array (see :mod:`layout`) from keyword names of its P_* constants, lower-case
    without the prefix, e.g. ``make_params(dt=1e-6, gz=-9.81, estar=...)``."""
    from . import layout

    p = np.zeros(P_SIZE)
    for key, value in values.items():
        p[getattr(layout, "P_" + key.upper())] = value
    return p
