"""Index layout of the flat parameter and head-state arrays shared by the njit kernels.

Numba kernels take plain ``float64`` arrays rather than objects; these constants name the slots.
All values SI (m, s, kg, Pa, rad).
"""

from __future__ import annotations

# ---- params: float64 array, shape (P_SIZE,) -----------------------------------------------
P_DT = 0            # time step, s
P_GZ = 1            # gravity along z, m/s² (negative = down)
P_ESTAR = 2         # E* = E / (2 (1 − ν²)), Pa (same for particle–particle and particle–wall)
P_GSTAR = 3         # G* = E / (4 (2 − ν)(1 + ν)), Pa
P_BETA = 4          # β = ln e / √(ln² e + π²)
P_MU = 5            # particle–particle sliding friction μs
P_MUR = 6           # particle–particle rolling friction μr
P_COH = 7           # SJKR cohesion energy density k, J/m³ (0 = off)
P_SKIN = 8          # neighbour-list skin, m
P_USE_CYL = 9       # 1 = cylindrical vessel wall on
P_RC = 10           # vessel radius, m
P_MU_WALL = 11      # vessel wall μs
P_MUR_WALL = 12     # vessel wall μr
P_USE_BASE = 13     # 1 = flat base (z = 0) on
P_MU_BASE = 14      # base (and ribs) μs
P_MUR_BASE = 15     # base (and ribs) μr
P_NRIBS = 16        # number of radial ribs on the base
P_RIB_H = 17        # rib height, m
P_USE_HEAD = 18     # 1 = bladed head on
P_HEAD_R = 19       # head radius, m
P_HUB_R = 20        # hub radius (blades start there), m
P_BLADE_H = 21      # blade height below the head's lower face, m
P_NBLADES = 22      # number of blades
P_MU_HEAD = 23      # head μs
P_MUR_HEAD = 24     # head μr
P_SECTOR = 25       # opening 2π/k of a periodic sector, rad (0 = the full cell)
P_CORE_R = 26       # radius of the sector's frictionless core round the axis, m (0 = none)
P_SIZE = 27

# ---- head: float64 array, shape (H_SIZE,) -------------------------------------------------
H_Z = 0             # height of the head's lower face above the base, m
H_VZ = 1            # vertical velocity, m/s
H_VREF = 2          # low-passed vertical velocity the servo damper acts against, m/s
H_PHI = 3           # rotation angle, rad
H_OMEGA = 4         # rotation rate, rad/s
H_MODE = 5          # 0 = prescribed velocity H_VCMD, 1 = servo on H_FTARGET
H_FTARGET = 6       # target normal force (downward load), N
H_MASS = 7          # servo mass, kg
H_DAMP = 8          # servo damping against (v − v_ref), N·s/m
H_TAU_REF = 9       # time constant of v_ref, s
H_VMAX = 10         # servo speed limit, m/s
H_VCMD = 11         # prescribed vertical velocity (mode 0), m/s
H_ACC_F = 12        # Σ over steps of the particles' upward force on the head, N
H_ACC_T = 13        # Σ over steps of the driving torque about z (resistance of the bed), N·m
H_ACC_BASE = 14     # Σ over steps of the base's (and ribs') upward force on the particles, N
H_ACC_N = 15        # number of steps accumulated
H_TIME = 16         # simulated time, s
H_SIZE = 17

# ---- per-particle wall-reaction scratch, shape (N, W_SIZE) ----------------------------------
W_HEAD_F = 0        # upward force of particle i on the head, N
W_HEAD_T = 1        # torque about z of particle i on the head (bed resistance, positive), N·m
W_BASE_F = 2        # upward force of base + ribs on particle i, N
W_SIZE = 3

#: wall-contact history slots per particle (cylinder, base, ribs, head disc, blades, core)
WALL_SLOTS = 6
