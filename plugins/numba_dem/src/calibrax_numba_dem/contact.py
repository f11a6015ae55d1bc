"""Contact law kernels: Hertz–Mindlin with LIGGGHTS ``model hertz`` damping, tangential history
(``tangential history``), EPSD2 rolling resistance and optional SJKR cohesion.

One function serves particle–particle and particle–wall contacts (a wall is infinite radius and
mass: R* = r_i, m* = m_i). Sign convention: ``n`` is the unit normal pointing from the other body
to particle i; the force F acts on particle i and −F on the other body. The torques follow from
the returned parts: on i it is −r_i (n × F_t) + M, on a particle j it is −r_j (n × F_t) − M, so a
pair computed once gives exactly opposite forces and rolling torques (Newton's third law bit for
bit).

A contact's history (tangential spring, m; rolling torque, N·m) is one row ``p`` of two arrays of
shape (P, 3): the pair's slot in the half neighbour list, or ``i · WALL_SLOTS + slot`` for walls.
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


@njit(cache=True, inline="always")
def tangential_spring(nx, ny, nz, vtx, vty, vtz, sx, sy, sz, kt, gt, flim, dt):
    """Mindlin spring with history and Coulomb limit, as LIGGGHTS 3.8's ``tangential history``
    (``tangential_model_history.h``) computes it:

    1. the spring grows by v_t Δt and is projected onto the tangent plane (no rescaling);
    2. if the *spring* force k_t|s| exceeds μs|F_n| the contact slides: the force is the spring's,
       scaled to μs|F_n|, the spring is cut back to match, and there is no dashpot;
    3. otherwise it sticks: F_t = −k_t s − γ_t v_t (the dashpot may carry it past μs|F_n|).

    Args:
        n*: unit normal. vt*: tangential relative velocity at the contact point, m/s.
        s*: the spring's displacement from the previous step, m. kt: N/m. gt: damping, N·s/m
            (negative, LIGGGHTS' sign). flim: μs|F_n|, N. dt: s.

    Returns:
        (Ftx, Fty, Ftz, sx, sy, sz): tangential force on i (N) and the updated spring (m).
    """
    sx += vtx * dt
    sy += vty * dt
    sz += vtz * dt
    sdn = sx * nx + sy * ny + sz * nz
    sx -= sdn * nx
    sy -= sdn * ny
    sz -= sdn * nz
    ftx = -kt * sx
    fty = -kt * sy
    ftz = -kt * sz
    ft2 = ftx * ftx + fty * fty + ftz * ftz
    if ft2 > flim * flim:
        ratio = flim / math.sqrt(ft2)
        ftx *= ratio
        fty *= ratio
        ftz *= ratio
        sx *= ratio
        sy *= ratio
        sz *= ratio
    else:
        ftx -= gt * vtx
        fty -= gt * vty
        ftz -= gt * vtz
    return ftx, fty, ftz, sx, sy, sz


@njit(cache=True, inline="always")
def rolling_spring(nx, ny, nz, wrx, wry, wrz, mx, my, mz, kr, mlim, dt):
    """EPSD2 rolling torque: elastic spring k_r on the relative rolling rotation, limited at mlim.

    Args:
        n*: unit normal. wr*: ω_i − ω_other, rad/s. m*: the torque of the previous step, N·m.
        kr: N·m/rad (EPSD2: k_t R*², see :func:`contact`). mlim: μr R*|F_n|, N·m. dt: s.

    Returns:
        (Mx, My, Mz): the rolling torque on i, N·m (also the new history).
    """
    wdn = wrx * nx + wry * ny + wrz * nz
    mx -= kr * (wrx - wdn * nx) * dt
    my -= kr * (wry - wdn * ny) * dt
    mz -= kr * (wrz - wdn * nz) * dt
    mdn = mx * nx + my * ny + mz * nz
    mx -= mdn * nx
    my -= mdn * ny
    mz -= mdn * nz
    mm2 = mx * mx + my * my + mz * mz
    if mm2 > mlim * mlim:
        ratio = mlim / math.sqrt(mm2)
        mx *= ratio
        my *= ratio
        mz *= ratio
    return mx, my, mz


@njit(cache=True, inline="always")
def contact(nx, ny, nz, delta, reff, meff,
            vrx, vry, vrz, rwx, rwy, rwz, wrx, wry, wrz,
            e_star, g_star, beta, mu, mur, coh, dt, hist, rhist, p):
    """Force on particle i from one contact, and the parts of the torques; updates the history.

    Args:
        nx, ny, nz: unit normal from the other body to i.
        delta: overlap, m (> 0). reff: R*, m. meff: m*, kg.
        vr*: v_i − v_other at the contact's translational part, m/s (a wall's surface velocity
            is already subtracted).
        rw*: r_i ω_i + r_j ω_j (walls: r_i ω_i), m/s.
        wr*: ω_i − ω_j (walls: ω_i − ω_wall), rad/s, for rolling resistance.
        e_star, g_star: Pa. beta: damping factor. mu, mur: sliding and rolling friction.
        coh: SJKR cohesion energy density, J/m³. dt: s.
        hist, rhist: shape (P, 3): tangential spring displacement (m) and rolling torque (N·m);
            this contact's row is ``p``.

    Returns:
        (Fx, Fy, Fz, Qx, Qy, Qz, Mx, My, Mz, Fn): force on i (N); Q = n × F_t (N), so that the
        tangential torque on i is −r_i Q and on a particle j −r_j Q; rolling torque M on i (N·m),
        −M on j; and the normal force (N).
    """
    sq = math.sqrt(reff * delta)
    kn = 4.0 / 3.0 * e_star * sq
    gn = -2.0 * SQRT_5_6 * beta * math.sqrt(2.0 * e_star * sq * meff)
    vn = vrx * nx + vry * ny + vrz * nz
    fn = kn * delta - gn * vn
    if coh > 0.0:
        # SJKR: k·A with A = 2π R* δ, the contact circle's area to first order in δ (LIGGGHTS'
        # cohesion sjkr computes it exactly: for two spheres from their intersection, π(2Rδ − δ²)
        # on a wall; calibrax.core.sheartest.cohesion)
        fn -= 2.0 * coh * math.pi * reff * delta
    fx = fn * nx
    fy = fn * ny
    fz = fn * nz
    qx = 0.0
    qy = 0.0
    qz = 0.0
    if mu > 0.0:
        kt = 8.0 * g_star * sq
        # γ_t = −2√(5/6) β √(k_t m*) = γ_n √(k_t / S_n), S_n = 2 E* √(R*δ)
        gt = gn * math.sqrt(4.0 * g_star / e_star)
        vtx = vrx - vn * nx - (rwy * nz - rwz * ny)
        vty = vry - vn * ny - (rwz * nx - rwx * nz)
        vtz = vrz - vn * nz - (rwx * ny - rwy * nx)
        ftx, fty, ftz, sx, sy, sz = tangential_spring(nx, ny, nz, vtx, vty, vtz, hist[p, 0], hist[p, 1],
                                                      hist[p, 2], kt, gt, mu * abs(fn), dt)
        hist[p, 0] = sx
        hist[p, 1] = sy
        hist[p, 2] = sz
        fx += ftx
        fy += fty
        fz += ftz
        qx = ny * ftz - nz * fty
        qy = nz * ftx - nx * ftz
        qz = nx * fty - ny * ftx
    mx = 0.0
    my = 0.0
    mz = 0.0
    if mur > 0.0:
        # EPSD2's rolling stiffness is k_t R*² (LIGGGHTS 3.8, rolling_model_epsd2.h), not the
        # original EPSD's 2.25 k_n μr² R*² (Ai et al. 2011), which is 2.3× softer at μr = 0.5, ν = 0.25
        kr = 8.0 * g_star * sq * reff * reff
        mx, my, mz = rolling_spring(nx, ny, nz, wrx, wry, wrz, rhist[p, 0], rhist[p, 1], rhist[p, 2],
                                    kr, mur * reff * abs(fn), dt)
        rhist[p, 0] = mx
        rhist[p, 1] = my
        rhist[p, 2] = mz
    return fx, fy, fz, qx, qy, qz, mx, my, mz, fn


@njit(cache=True, inline="always")
def clear_history(hist, rhist, p):
    """Zero the tangential and rolling history of a contact that has opened (row ``p``)."""
    for c in range(3):
        hist[p, c] = 0.0
        rhist[p, c] = 0.0


@njit(cache=True, inline="always")
def has_history(hist, rhist, p):
    """Whether row ``p`` holds any tangential or rolling history."""
    return (hist[p, 0] != 0.0 or hist[p, 1] != 0.0 or hist[p, 2] != 0.0
            or rhist[p, 0] != 0.0 or rhist[p, 1] != 0.0 or rhist[p, 2] != 0.0)


__all__ = ["contact", "clear_history", "has_history", "tangential_spring", "rolling_spring",
           "beta_from_restitution", "effective_moduli"]
