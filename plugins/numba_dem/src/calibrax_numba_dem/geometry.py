"""Analytic boundaries of the FT4 cell: cylindrical vessel wall, flat base with optional radial
ribs, the bladed shear head (a disc of radius R_head whose lower face is at height z_h, with
``blade_count`` thin radial blades of height h_b hanging below it from the hub to the rim), and a
periodic sector's frictionless core round the axis.

Every boundary is exact geometry (no mesh): each particle finds its closest point on each
element, and the contact law of :mod:`contact` is applied with the wall as a body of infinite
radius and mass. Wall-contact history lives in ``WALL_SLOTS`` slots per particle keyed by element
id (0 cylinder, 1 base, 2 head disc, 3… blades, 999 the core, then ribs); slot s of particle i is row
``i · WALL_SLOTS + s`` of the wall history arrays. The blades' and ribs' directions are computed
once per step (:func:`element_directions`), not per particle.
"""

from __future__ import annotations

import math

from numba import njit

from .contact import clear_history, contact
from .layout import (H_OMEGA, H_PHI, H_VZ, H_Z, P_BETA, P_BLADE_H, P_COH, P_DT, P_ESTAR, P_GSTAR,
                     P_CORE_R, P_HEAD_R, P_HUB_R, P_MU_BASE, P_MU_HEAD, P_MU_WALL, P_MUR_BASE,
                     P_MUR_HEAD, P_MUR_WALL, P_NBLADES, P_NRIBS, P_RC, P_RIB_H, P_USE_BASE,
                     P_USE_CYL, P_USE_HEAD, WALL_SLOTS)

EID_CYL = 0
EID_BASE = 1
EID_DISC = 2
EID_BLADE0 = 3
#: the ribs' ids start here, whatever the number of blades, so that a rib contact keeps its history
#: when the head's blades are retracted (the compressibility test's flat piston)
EID_RIB0 = 1000
#: the periodic sector's frictionless core round the axis (calibrax.core.sheartest.sector)
EID_CORE = 999


@njit(cache=True, inline="always")
def _slot(wid, i, eid):
    """Slot of element ``eid`` in particle i's wall history (claiming a free one), or −1."""
    free = -1
    for s in range(WALL_SLOTS):
        if wid[i, s] == eid:
            return s
        if free < 0 and wid[i, s] < 0:
            free = s
    if free >= 0:
        wid[i, free] = eid
    return free


@njit(cache=True, inline="always")
def _plate_closest(px, py, pz, ca, sa, s0, s1, z0, z1):
    """Closest point of a vertical radial plate {s e_α + z e_z: s∈[s0,s1], z∈[z0,z1]} to p.

    Returns (qx, qy, qz, distance) with q the closest point, m.
    """
    s = px * ca + py * sa
    if s < s0:
        s = s0
    elif s > s1:
        s = s1
    z = pz
    if z < z0:
        z = z0
    elif z > z1:
        z = z1
    qx = s * ca
    qy = s * sa
    dx = px - qx
    dy = py - qy
    dz = pz - z
    return qx, qy, z, math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True)
def element_directions(params, head, out):
    """Unit directions (cos α, sin α) of the blades (rows 0 … n_blades − 1, turning with the head)
    and of the ribs (the next n_ribs rows), into ``out`` of shape (≥ n_blades + n_ribs, 2)."""
    nblades = int(params[P_NBLADES])
    nribs = int(params[P_NRIBS])
    for k in range(nblades):
        ang = head[H_PHI] + 2.0 * math.pi * k / nblades
        out[k, 0] = math.cos(ang)
        out[k, 1] = math.sin(ang)
    for k in range(nribs):
        ang = 2.0 * math.pi * k / nribs
        out[nblades + k, 0] = math.cos(ang)
        out[nblades + k, 1] = math.sin(ang)


@njit(cache=True, inline="always")
def _touch(i, eid, nx, ny, nz, delta, vwx, vwy, vwz, wwz, mu, mur, r, m, v, w, params, wid, whist, wrhist):
    """One wall contact of particle i with element ``eid`` (unit normal n from the wall to i,
    overlap ``delta`` m, surface velocity vw m/s and spin wwz rad/s about z).

    Returns (slot, Fx, Fy, Fz, Tx, Ty, Tz): the history slot used (−1: none free, contact
    ignored) and the force (N) and torque (N·m) on i."""
    s = _slot(wid, i, eid)
    if s < 0:
        return s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    fx, fy, fz, qx, qy, qz, mx, my, mz, _ = contact(
        nx, ny, nz, delta, r, m,
        v[i, 0] - vwx, v[i, 1] - vwy, v[i, 2] - vwz,
        r * w[i, 0], r * w[i, 1], r * w[i, 2],
        w[i, 0], w[i, 1], w[i, 2] - wwz,
        params[P_ESTAR], params[P_GSTAR], params[P_BETA], mu, mur, params[P_COH], params[P_DT],
        whist, wrhist, i * WALL_SLOTS + s)
    return s, fx, fy, fz, mx - r * qx, my - r * qy, mz - r * qz


@njit(cache=True, inline="always")
def _release_slots(i, touched, wid, whist, wrhist):
    """Free the wall slots of particle i not in the bit mask ``touched``, zeroing their history."""
    for s in range(WALL_SLOTS):
        if wid[i, s] >= 0 and not (touched >> s) & 1:
            wid[i, s] = -1
            clear_history(whist, wrhist, i * WALL_SLOTS + s)


@njit(cache=True, inline="always")
def wall_forces(i, x, v, w, rad, mass, params, head, dirs, wid, whist, wrhist):
    """Sum of wall forces on particle i.

    Args:
        i: particle index. x, v, w: positions (m), velocities (m/s), angular velocities (rad/s),
            each shape (N, 3). rad, mass: shape (N,). params, head: see :mod:`layout`.
        dirs: blade and rib directions from :func:`element_directions`, shape (≥ n_el, 2).
        wid: element id per slot, shape (N, WALL_SLOTS), −1 = free. whist, wrhist: tangential
            displacement (m) and rolling torque (N·m) per slot, shape (N · WALL_SLOTS, 3).

    Returns:
        (Fx, Fy, Fz, Tx, Ty, Tz, F_head_up, T_head, F_base_up): force and torque on i; upward force
        of i on the head (N); torque of i on the head about z, counted positive when it resists
        the head's rotation (N·m); upward force of base and ribs on i (N).
    """
    r = rad[i]
    m = mass[i]
    px = x[i, 0]
    py = x[i, 1]
    pz = x[i, 2]
    fx = 0.0
    fy = 0.0
    fz = 0.0
    tx = 0.0
    ty = 0.0
    tz = 0.0
    fh = 0.0
    th = 0.0
    fb = 0.0
    touched = 0  # bit mask of slots used this step
    # ---- vessel wall
    if params[P_USE_CYL] > 0.0:
        rc = params[P_RC]
        rho2 = px * px + py * py
        if rho2 > (rc - r) * (rc - r) and rho2 > 0.0:
            rho = math.sqrt(rho2)
            s, cfx, cfy, cfz, ctx, cty, ctz = _touch(i, EID_CYL, -px / rho, -py / rho, 0.0, r - (rc - rho),
                                                     0.0, 0.0, 0.0, 0.0, params[P_MU_WALL], params[P_MUR_WALL],
                                                     r, m, v, w, params, wid, whist, wrhist)
            if s >= 0:
                touched |= 1 << s
                fx += cfx
                fy += cfy
                fz += cfz
                tx += ctx
                ty += cty
                tz += ctz
    # ---- the sector's core: a frictionless cylinder round the axis, the particles outside it
    core = params[P_CORE_R]
    if core > 0.0:
        rho2 = px * px + py * py
        if rho2 < (core + r) * (core + r):
            rho = math.sqrt(rho2)
            s, cfx, cfy, cfz, ctx, cty, ctz = _touch(i, EID_CORE, px / rho, py / rho, 0.0, r - (rho - core),
                                                     0.0, 0.0, 0.0, 0.0, 0.0, 0.0, r, m, v, w, params, wid,
                                                     whist, wrhist)
            if s >= 0:
                touched |= 1 << s
                fx += cfx
                fy += cfy
                fz += cfz
                tx += ctx
                ty += cty
                tz += ctz
    # ---- base
    if params[P_USE_BASE] > 0.0 and pz < r:
        s, cfx, cfy, cfz, ctx, cty, ctz = _touch(i, EID_BASE, 0.0, 0.0, 1.0, r - pz, 0.0, 0.0, 0.0, 0.0,
                                                 params[P_MU_BASE], params[P_MUR_BASE], r, m, v, w, params,
                                                 wid, whist, wrhist)
        if s >= 0:
            touched |= 1 << s
            fx += cfx
            fy += cfy
            fz += cfz
            tx += ctx
            ty += cty
            tz += ctz
            fb += cfz
    # ---- head: disc and blades (moving: surface velocity ω ẑ × q + v_z ẑ at the contact point q)
    nblades = int(params[P_NBLADES])
    zh = head[H_Z]
    hb = params[P_BLADE_H]
    if params[P_USE_HEAD] > 0.0 and pz < zh + r and pz > zh - hb - r:
        rh = params[P_HEAD_R]
        om = head[H_OMEGA]
        vz = head[H_VZ]
        mu_h = params[P_MU_HEAD]
        mur_h = params[P_MUR_HEAD]
        for eid in range(EID_DISC, EID_BLADE0 + nblades):
            hit = False
            qx = 0.0
            qy = 0.0
            qz = 0.0
            dist = 0.0
            if eid == EID_DISC:
                if abs(pz - zh) < r:
                    rho2 = px * px + py * py
                    if rho2 < (rh + r) * (rh + r):
                        qx = px
                        qy = py
                        if rho2 > rh * rh:
                            sc = rh / math.sqrt(rho2)
                            qx = px * sc
                            qy = py * sc
                        qz = zh
                        dist = math.sqrt((px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2)
                        hit = dist < r and dist > 0.0
            else:
                ca = dirs[eid - EID_BLADE0, 0]
                sa = dirs[eid - EID_BLADE0, 1]
                if abs(py * ca - px * sa) < r:
                    qx, qy, qz, dist = _plate_closest(px, py, pz, ca, sa, params[P_HUB_R], rh, zh - hb, zh)
                    hit = dist < r and dist > 0.0
            if not hit:
                continue
            s, cfx, cfy, cfz, ctx, cty, ctz = _touch(i, eid, (px - qx) / dist, (py - qy) / dist, (pz - qz) / dist,
                                                     r - dist, -om * qy, om * qx, vz, om, mu_h, mur_h, r, m, v, w,
                                                     params, wid, whist, wrhist)
            if s < 0:
                continue  # more simultaneous wall contacts than slots: ignore the extra one
            touched |= 1 << s
            fx += cfx
            fy += cfy
            fz += cfz
            tx += ctx
            ty += cty
            tz += ctz
            # the head receives −F at the contact point c = p − r n and −M_roll; its resisting
            # torque about z is (c × F)_z + M_roll,z = (p × F)_z + T_z (T: torque on i)
            fh -= cfz
            th += px * cfy - py * cfx + ctz
    # ---- ribs on the base, from the hub radius to the wall (not from the axis, where every rib's
    # inner edge would meet and wedge a particle among them all)
    nribs = int(params[P_NRIBS])
    hr = params[P_RIB_H]
    if nribs > 0 and pz < hr + r:
        for k in range(nribs):
            ca = dirs[nblades + k, 0]
            sa = dirs[nblades + k, 1]
            if abs(py * ca - px * sa) >= r:
                continue
            qx, qy, qz, dist = _plate_closest(px, py, pz, ca, sa, params[P_HUB_R], params[P_RC], 0.0, hr)
            if not (dist < r and dist > 0.0):
                continue
            s, cfx, cfy, cfz, ctx, cty, ctz = _touch(i, EID_RIB0 + k, (px - qx) / dist,
                                                     (py - qy) / dist, (pz - qz) / dist, r - dist, 0.0, 0.0,
                                                     0.0, 0.0, params[P_MU_BASE], params[P_MUR_BASE], r, m, v, w,
                                                     params, wid, whist, wrhist)
            if s < 0:
                continue
            touched |= 1 << s
            fx += cfx
            fy += cfy
            fz += cfz
            tx += ctx
            ty += cty
            tz += ctz
            fb += cfz
    _release_slots(i, touched, wid, whist, wrhist)
    return fx, fy, fz, tx, ty, tz, fh, th, fb
