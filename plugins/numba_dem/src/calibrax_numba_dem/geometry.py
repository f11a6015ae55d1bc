"""Analytic boundaries of the FT4 cell: cylindrical vessel wall, flat base with optional radial
ribs, and the bladed shear head (a disc of radius R_head whose lower face is at height z_h, with
``blade_count`` thin radial blades of height h_b hanging below it from the hub to the rim).

Every boundary is exact geometry (no mesh): each particle finds its closest point on each
element, and the contact law of :mod:`contact` is applied with the wall as a body of infinite
radius and mass. Wall-contact history lives in ``WALL_SLOTS`` slots per particle keyed by element
id (0 cylinder, 1 base, 2 head disc, 3… blades, then ribs).
"""

from __future__ import annotations

import math

from numba import njit

from .contact import clear_history, contact
from .layout import (H_OMEGA, H_PHI, H_VZ, H_Z, P_BETA, P_BLADE_H, P_COH, P_DT, P_ESTAR, P_GSTAR,
                     P_HEAD_R, P_HUB_R, P_MU_BASE, P_MU_HEAD, P_MU_WALL, P_MUR_BASE,
                     P_MUR_HEAD, P_MUR_WALL, P_NBLADES, P_NRIBS, P_RC, P_RIB_H, P_USE_BASE,
                     P_USE_CYL, P_USE_HEAD, WALL_SLOTS)

EID_CYL = 0
EID_BASE = 1
EID_DISC = 2
EID_BLADE0 = 3


@njit(cache=True)
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


@njit(cache=True)
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
def wall_forces(i, x, v, w, rad, mass, params, head, wid, whist, wrhist):
    """Sum of wall forces on particle i.

    Args:
        i: particle index. x, v, w: positions (m), velocities (m/s), angular velocities (rad/s),
            each shape (N, 3). rad, mass: shape (N,). params, head: see :mod:`layout`.
        wid: element id per slot, shape (N, WALL_SLOTS), −1 = free. whist, wrhist: tangential
            displacement (m) and rolling torque (N·m) per slot, shape (N, WALL_SLOTS, 3).

    Returns:
        (Fx, Fy, Fz, Tx, Ty, Tz, F_head_up, T_head, F_base_up): force and torque on i; upward force
        of i on the head (N); torque of i on the head about z, counted positive when it resists
        the head's rotation (N·m); upward force of base and ribs on i (N).
    """
    dt = params[P_DT]
    e_star = params[P_ESTAR]
    g_star = params[P_GSTAR]
    beta = params[P_BETA]
    coh = params[P_COH]
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
    nblades = int(params[P_NBLADES])
    nribs = int(params[P_NRIBS])
    n_el = 3 + nblades + nribs
    zh = head[H_Z]
    use_head = params[P_USE_HEAD] > 0.0
    rh = params[P_HEAD_R]
    hb = params[P_BLADE_H]
    for eid in range(n_el):
        # ---- closest point q on element eid, its surface velocity, friction -----------------
        hit = False
        qx = 0.0
        qy = 0.0
        qz = 0.0
        dist = 0.0
        nx = 0.0
        ny = 0.0
        nz = 0.0
        vwx = 0.0
        vwy = 0.0
        vwz = 0.0
        wwz = 0.0
        mu = 0.0
        mur = 0.0
        is_head = False
        is_base = False
        if eid == EID_CYL:
            if params[P_USE_CYL] > 0.0:
                rho = math.sqrt(px * px + py * py)
                rc = params[P_RC]
                if rho + r > rc and rho > 0.0:
                    hit = True
                    dist = rc - rho
                    nx = -px / rho
                    ny = -py / rho
                    nz = 0.0
                    mu = params[P_MU_WALL]
                    mur = params[P_MUR_WALL]
        elif eid == EID_BASE:
            if params[P_USE_BASE] > 0.0 and pz < r:
                hit = True
                dist = pz
                nz = 1.0
                mu = params[P_MU_BASE]
                mur = params[P_MUR_BASE]
                is_base = True
        elif eid == EID_DISC:
            if use_head and abs(pz - zh) < r:
                rho = math.sqrt(px * px + py * py)
                if rho < rh + r:
                    if rho <= rh:
                        qx = px
                        qy = py
                    else:
                        qx = px * rh / rho
                        qy = py * rh / rho
                    qz = zh
                    dx = px - qx
                    dy = py - qy
                    dz = pz - qz
                    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
                    if dist < r and dist > 0.0:
                        hit = True
                        nx = dx / dist
                        ny = dy / dist
                        nz = dz / dist
                        is_head = True
        elif eid < 3 + nblades:
            if use_head and pz < zh + r and pz > zh - hb - r:
                ang = head[H_PHI] + 2.0 * math.pi * (eid - 3) / nblades
                ca = math.cos(ang)
                sa = math.sin(ang)
                perp = -px * sa + py * ca
                if abs(perp) < r:
                    qx, qy, qz, dist = _plate_closest(px, py, pz, ca, sa, params[P_HUB_R], rh, zh - hb, zh)
                    if dist < r and dist > 0.0:
                        hit = True
                        nx = (px - qx) / dist
                        ny = (py - qy) / dist
                        nz = (pz - qz) / dist
                        is_head = True
        else:
            hr = params[P_RIB_H]
            if pz < hr + r:
                ang = 2.0 * math.pi * (eid - 3 - nblades) / nribs
                ca = math.cos(ang)
                sa = math.sin(ang)
                perp = -px * sa + py * ca
                if abs(perp) < r:
                    qx, qy, qz, dist = _plate_closest(px, py, pz, ca, sa, 0.0, params[P_RC], 0.0, hr)
                    if dist < r and dist > 0.0:
                        hit = True
                        nx = (px - qx) / dist
                        ny = (py - qy) / dist
                        nz = (pz - qz) / dist
                        mu = params[P_MU_BASE]
                        mur = params[P_MUR_BASE]
                        is_base = True
        if not hit:
            continue
        if is_head:
            om = head[H_OMEGA]
            vwx = -om * qy
            vwy = om * qx
            vwz = head[H_VZ]
            wwz = om
            mu = params[P_MU_HEAD]
            mur = params[P_MUR_HEAD]
        s = _slot(wid, i, eid)
        if s < 0:
            continue  # more simultaneous wall contacts than slots: ignore the extra one
        touched |= 1 << s
        delta = r - dist
        cfx, cfy, cfz, ctx, cty, ctz, fn = contact(
            nx, ny, nz, delta, r, m, r,
            v[i, 0] - vwx, v[i, 1] - vwy, v[i, 2] - vwz,
            r * w[i, 0], r * w[i, 1], r * w[i, 2],
            w[i, 0], w[i, 1], w[i, 2] - wwz,
            e_star, g_star, beta, mu, mur, coh, dt, whist, wrhist, i, s)
        fx += cfx
        fy += cfy
        fz += cfz
        tx += ctx
        ty += cty
        tz += ctz
        if is_head:
            # the head receives −F at the contact point c = p − r n and −M_roll; its resisting
            # torque about z is (c × F)_z + M_roll,z = (p × F)_z + T_z (T: torque on i)
            fh -= cfz
            th += px * cfy - py * cfx + ctz
        if is_base:
            fb += cfz
    for s in range(WALL_SLOTS):
        if wid[i, s] >= 0 and not (touched >> s) & 1:
            wid[i, s] = -1
            clear_history(whist, wrhist, i, s)
    return fx, fy, fz, tx, ty, tz, fh, th, fb
