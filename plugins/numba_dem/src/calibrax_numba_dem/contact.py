"""Contact law kernels: Hertz–Mindlin with LIGGGHTS ``model hertz`` damping, tangential history
(``tangential history``), EPSD2 rolling resistance and optional SJKR cohesion.

One function serves particle–particle and particle–wall contacts (a wall is infinite radius and
mass: R* = r_i, m* = m_i). Sign convention: ``n`` is the unit normal pointing from the other body
to particle i; the returned force and torque act on particle i. Computing a pair from either side
gives exactly opposite forces and torques (every operation is sign-symmetric), so full neighbour
lists reproduce Newton's third law bit for bit.
"""

from __future__ import annotations

import math

from numba import njit

SQRT_5_6 = math.sqrt(5.0 / 6.0)


def beta_from_restitution(e: float) -> float:
    """β = ln e / √(ln² e + π²) (0 for e = 1)."""
    if e >= 1.0:
        return 0.0
    le = math.log(e)
    return le / math.sqrt(le * le + math.pi * math.pi)


def effective_moduli(youngs_modulus: float, poisson_ratio: float) -> tuple[float, float]:
    """(E*, G*) of two bodies of the same material, Pa: E* = E/(2(1−ν²)), G* = E/(4(2−ν)(1+ν))."""
    e, nu = youngs_modulus, poisson_ratio
    return e / (2.0 * (1.0 - nu * nu)), e / (4.0 * (2.0 - nu) * (1.0 + nu))


@njit(cache=True, fastmath=False)
def contact(nx, ny, nz, delta, reff, meff, ri,
            vrx, vry, vrz, rwx, rwy, rwz, wrx, wry, wrz,
            e_star, g_star, beta, mu, mur, coh, dt,
            hist, rhist, a, b):
    """Force and torque on particle i from one contact; updates its history in place.

    Args:
        nx, ny, nz: unit normal from the other body to i.
        delta: overlap, m (> 0). reff: R*, m. meff: m*, kg. ri: radius of i, m.
        vr*: v_i − v_other at the contact's translational part, m/s (a wall's surface velocity
            is already subtracted).
        rw*: r_i ω_i + r_j ω_j (walls: r_i ω_i), m/s.
        wr*: ω_i − ω_j (walls: ω_i − ω_wall), rad/s, for rolling resistance.
        e_star, g_star: Pa. beta: damping factor. mu, mur: sliding and rolling friction.
        coh: SJKR cohesion energy density, J/m³. dt: s.
        hist, rhist: arrays of shape (..., ..., 3): tangential spring displacement (m) and rolling
            torque (N·m) of this directed contact, at hist[a, b].

    Returns:
        (Fx, Fy, Fz, Tx, Ty, Tz, Fn): force (N) and torque (N·m) on i, and the normal force (N).
    """
    sq = math.sqrt(reff * delta)
    kn = 4.0 / 3.0 * e_star * sq
    sn = 2.0 * e_star * sq
    kt = 8.0 * g_star * sq
    gn = -2.0 * SQRT_5_6 * beta * math.sqrt(sn * meff)
    gt = -2.0 * SQRT_5_6 * beta * math.sqrt(kt * meff)
    vn = vrx * nx + vry * ny + vrz * nz
    fn = kn * delta - gn * vn
    if coh > 0.0:
        fn -= coh * math.pi * reff * delta
    fx = fn * nx
    fy = fn * ny
    fz = fn * nz
    tx = 0.0
    ty = 0.0
    tz = 0.0
    if mu > 0.0:
        # tangential relative velocity at the contact point
        cx = rwy * nz - rwz * ny
        cy = rwz * nx - rwx * nz
        cz = rwx * ny - rwy * nx
        vtx = vrx - vn * nx - cx
        vty = vry - vn * ny - cy
        vtz = vrz - vn * nz - cz
        sx = hist[a, b, 0] + vtx * dt
        sy = hist[a, b, 1] + vty * dt
        sz = hist[a, b, 2] + vtz * dt
        # keep the spring in the tangent plane, preserving its length
        old = math.sqrt(sx * sx + sy * sy + sz * sz)
        sdn = sx * nx + sy * ny + sz * nz
        sx -= sdn * nx
        sy -= sdn * ny
        sz -= sdn * nz
        new = math.sqrt(sx * sx + sy * sy + sz * sz)
        if new > 0.0:
            sc = old / new
            sx *= sc
            sy *= sc
            sz *= sc
        ftx = -(kt * sx + gt * vtx)
        fty = -(kt * sy + gt * vty)
        ftz = -(kt * sz + gt * vtz)
        ft = math.sqrt(ftx * ftx + fty * fty + ftz * ftz)
        flim = mu * abs(fn)
        if ft > flim:
            if ft > 0.0:
                ratio = flim / ft
                ftx *= ratio
                fty *= ratio
                ftz *= ratio
            if kt > 0.0:
                sx = -(ftx + gt * vtx) / kt
                sy = -(fty + gt * vty) / kt
                sz = -(ftz + gt * vtz) / kt
        hist[a, b, 0] = sx
        hist[a, b, 1] = sy
        hist[a, b, 2] = sz
        fx += ftx
        fy += fty
        fz += ftz
        # torque of the tangential force at the contact point −r_i n
        tx = -ri * (ny * ftz - nz * fty)
        ty = -ri * (nz * ftx - nx * ftz)
        tz = -ri * (nx * fty - ny * ftx)
    if mur > 0.0:
        wdn = wrx * nx + wry * ny + wrz * nz
        kr = 2.25 * kn * mur * mur * reff * reff
        mx = rhist[a, b, 0] - kr * (wrx - wdn * nx) * dt
        my = rhist[a, b, 1] - kr * (wry - wdn * ny) * dt
        mz = rhist[a, b, 2] - kr * (wrz - wdn * nz) * dt
        mdn = mx * nx + my * ny + mz * nz
        mx -= mdn * nx
        my -= mdn * ny
        mz -= mdn * nz
        mm = math.sqrt(mx * mx + my * my + mz * mz)
        mlim = mur * reff * abs(fn)
        if mm > mlim and mm > 0.0:
            ratio = mlim / mm
            mx *= ratio
            my *= ratio
            mz *= ratio
        rhist[a, b, 0] = mx
        rhist[a, b, 1] = my
        rhist[a, b, 2] = mz
        tx += mx
        ty += my
        tz += mz
    return fx, fy, fz, tx, ty, tz, fn


@njit(cache=True)
def clear_history(hist, rhist, a, b):
    """Zero the tangential and rolling history of a contact that has opened."""
    for c in range(3):
        hist[a, b, c] = 0.0
        rhist[a, b, c] = 0.0


__all__ = ["contact", "clear_history", "beta_from_restitution", "effective_moduli"]
