"""The shear head's vertical motion: prescribed velocity, or a stress servo.

The servo treats the head as a rigid body of mass M under the target load F* (downward) and the
particles' upward force F_p, with a damper that acts only on the *fast* part of its motion:

    M dv/dt = F_p − F* − c (v − v_ref),    dv_ref/dt = (v − v_ref) / τ_ref,    |v| ≤ v_max.

Because the damper pushes against v − v_ref rather than v, a steady drift (the bed dilating or
compacting under shear) costs no force, so the time-averaged F_p equals F* (Newton), while the
head–bed oscillation (period 2π√(M/k_bed)) is damped. This is the "head as a rigid body under the
target load with its own mass and damping" (docs/explanation/shear-test.md), which a proportional velocity servo is
not. The speed limit keeps the approach gentle (the head is never driven blindly into the bed).

Integrating the law over a recording window of length T (speed limit inactive) gives its mean
force error exactly:

    ⟨F_p⟩ − F* = (M Δv + c τ_ref Δv_ref) / T,

where Δv, Δv_ref are the changes of v and v_ref over the window: the bias comes from the head
speeding up or slowing down as the bed compacts or dilates, weighted by M and by c τ_ref. With
c = 2√(k M) and τ_ref = q · 2π√(M/k), c τ_ref = 4πq M, so the bias is (1 + 4πq) M Δv / T. The
gains therefore use a light head (a quarter of the bed's mass) and q = 1 period (was: the bed's
mass and five periods, 19 times the bias; preshear windows of ``quick`` ran 6–9 % above target).
The damper still acts on the head–bed resonance (its high-pass passes 99 % at the resonance).
The gains are computed by :func:`calibrax.core.sheartest.servo.servo_gains`, shared with LIGGGHTS.
"""

from __future__ import annotations

from numba import njit

from .layout import (H_DAMP, H_FTARGET, H_MASS, H_MODE, H_OMEGA, H_PHI, H_TAU_REF, H_VCMD,
                     H_VMAX, H_VREF, H_VZ, H_Z)


@njit(cache=True)
def head_drift(head, dt):
    """Advance the head's height and angle by one step, s."""
    head[H_Z] += head[H_VZ] * dt
    head[H_PHI] += head[H_OMEGA] * dt


@njit(cache=True)
def head_kick(head, f_up, dt):
    """Update the head's vertical velocity from the particles' upward force ``f_up`` (N)."""
    if head[H_MODE] < 0.5:
        head[H_VZ] = head[H_VCMD]
        head[H_VREF] = head[H_VCMD]
        return
    v = head[H_VZ]
    acc = (f_up - head[H_FTARGET] - head[H_DAMP] * (v - head[H_VREF])) / head[H_MASS]
    v += acc * dt
    vmax = head[H_VMAX]
    if v > vmax:
        v = vmax
    elif v < -vmax:
        v = -vmax
    head[H_VZ] = v
    # a conditional, not min(): the CUDA path compiles this function too (cuda_engine), and Numba's
    # CUDA min() cannot be compiled without a GPU at hand (cuda_engine.compile_ptx)
    gain = dt / head[H_TAU_REF]
    head[H_VREF] += (v - head[H_VREF]) * (gain if gain < 1.0 else 1.0)
