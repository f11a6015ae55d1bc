"""Reading a step's time series: the preshear's steady part and how steady it ended, the steady-
state schedule, and the peak of a shear step (the maximum of a running mean) with the σ under it."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from calibrax.core.sheartest.spec import Procedure

def steady_window_samples(rotation: np.ndarray, window: float) -> int:
    """Samples in one steady-state window of ``window`` rad: window / (rotation per sample),
    rounded, at least 1; ``rotation`` (rad, shape (n,), n ≥ 2) is a step's record."""
    rot = np.asarray(rotation, dtype=float)
    per_sample = (rot[-1] - rot[0]) / max(rot.size - 1, 1)
    return max(1, int(round(window / per_sample))) if per_sample > 0 else 1


def preshear_drift(rotation: np.ndarray, shear_stress: np.ndarray, normal_stress: np.ndarray,
                   window: float) -> float:
    """How far from steady a preshear ended: the relative difference of τ/σ (mean τ over mean σ)
    between the last M samples and the M before them, |m_last − m_before| / |m_last|, with M the
    samples in ``window`` rad (:func:`steady_window_samples`); NaN when there are fewer than 2M.

    Args:
        rotation: head rotation since the step's start, shape (n,), rad, evenly sampled.
        shear_stress, normal_stress: τ and σ, shape (n,), Pa.
        window: width of each window, rad.

    Every backend stops a capped preshear (``Procedure.preshear_max_rotation``) by this quantity
    (numba_dem calls it, YADE's script carries a copy, LIGGGHTS' script evaluates the same window
    means with two ``fix ave/time``), checked on the schedule of :func:`steady_schedule`.
    """
    tau = np.asarray(shear_stress, dtype=float)
    if tau.size < 2:
        return math.nan
    m = steady_window_samples(rotation, window)
    if tau.size < 2 * m:
        return math.nan
    sig = np.asarray(normal_stress, dtype=float)
    m_last = float(np.sum(tau[-m:]) / np.sum(sig[-m:]))
    m_before = float(np.sum(tau[-2 * m:-m]) / np.sum(sig[-2 * m:-m]))
    return abs(m_last - m_before) / abs(m_last) if m_last != 0 else math.inf


#: the part of a fixed (uncapped) preshear taken as its steady state: the last 40 % of its samples
FIXED_PRESHEAR_STEADY_FRACTION = 0.4


def preshear_steady_part(rotation: np.ndarray, procedure: "Procedure") -> slice:
    """The samples of a preshear (``rotation`` in rad since its start, shape (n,)) whose mean τ/σ is
    its steady value: everything after its first ``procedure.steady_window`` of rotation (the
    transient after the head is loaded back to the preshear stress) for a preshear that runs until
    steady (``preshear_max_rotation`` set), else its last 40 % of samples.

    All the steady rotation is averaged, because what scatters is τ's own fluctuation from one
    stretch of rotation to the next, not the packing: at ``tiny`` (10 seeds, Table 1) a preshear's
    τ/σ scattered by 0.11 over its last 40 % and the mean of the four by 0.042; over all but its
    first 0.1 rad, 0.025 (``benchmarks/seed_noise.py``, which splits the scatter).
    """
    rot = np.asarray(rotation, dtype=float)
    n = rot.size
    fixed = slice(int((1.0 - FIXED_PRESHEAR_STEADY_FRACTION) * n), None)
    if procedure.preshear_max_rotation is None or n == 0:
        return fixed
    start = int(np.searchsorted(rot, procedure.steady_window, side="left"))
    return slice(start, None) if n - start >= max(2, n - fixed.start) else fixed


def steady_schedule(procedure: "Procedure", rotation_per_sample: float) -> tuple[int, int, int, int]:
    """When a backend checks a capped preshear for steadiness, in samples of ``rotation_per_sample``
    rad: (first check, last sample, window M, check every). The first check comes after
    max(the minimum rotation, 2M) samples, then one every max(1, M // 5) samples until the cap;
    every backend follows it, so the same record stops at the same sample."""
    n_min = max(2, int(math.ceil(procedure.preshear_rotation / rotation_per_sample - 1e-9)))
    cap = procedure.preshear_max_rotation
    n_max = n_min if cap is None else max(n_min, int(math.ceil(cap / rotation_per_sample - 1e-9)))
    m = max(1, int(round(procedure.steady_window / rotation_per_sample)))
    return min(max(n_min, 2 * m), n_max), n_max, m, max(1, m // 5)


def running_mean_width(rotation: np.ndarray, window: float) -> int:
    """Samples in the running mean of :func:`find_peak`: ``window`` (rad) over the rotation per
    sample of ``rotation`` (rad, shape (n,)), rounded, between 1 and n."""
    rot = np.asarray(rotation, dtype=float)
    step = (rot[-1] - rot[0]) / max(rot.size - 1, 1) if rot.size else 0.0
    width = max(1, int(round(window / step))) if step > 0 else 1
    return min(width, max(rot.size, 1))


def stress_at_peak(rotation: np.ndarray, normal_stress: np.ndarray, window: float, centre: int) -> float:
    """σ (Pa) over the same running-mean window as the peak found at sample ``centre`` by
    :func:`find_peak`: the mean of ``normal_stress`` (shape (n,)) over those samples. (A single
    sample's σ, which in a 600-particle bed swings by ±10 % from one sample to the next, put
    0.08 of seed scatter on the mean peak τ/σ at ``tiny`` where the window's mean put 0.045.)"""
    if centre < 0:
        return float("nan")
    width = running_mean_width(rotation, window)
    start = max(0, centre - width // 2)
    return float(np.mean(np.asarray(normal_stress, dtype=float)[start:start + width]))


def find_peak(rotation: np.ndarray, shear_stress: np.ndarray, window: float) -> tuple[float, int, float]:
    """The peak of a shear step: the maximum of a running mean of width ``window`` (rad).

    Args:
        rotation: head rotation since the step's start, shape (n,), rad, non-decreasing.
        shear_stress: τ, shape (n,), Pa.
        window: width of the running mean, rad.

    Returns:
        (τ_peak in Pa, index of the peak sample, position of the peak as a fraction of the
        step's rotation: near 1 means the window was too short to pass the peak).
    """
    rot = np.asarray(rotation, dtype=float)
    tau = np.asarray(shear_stress, dtype=float)
    if rot.size == 0:
        return float("nan"), -1, float("nan")
    span = rot[-1] - rot[0]
    width = running_mean_width(rot, window)
    kernel = np.ones(width) / width
    smooth = np.convolve(tau, kernel, mode="valid")
    i = int(np.argmax(smooth))
    centre = i + width // 2
    position = float((rot[centre] - rot[0]) / span) if span > 0 else 1.0
    return float(smooth[i]), centre, position
