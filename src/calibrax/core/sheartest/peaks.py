"""Reading a step's time series: the preshear's steady part and how steady it ended, the steady-
state schedule, and the peak of a shear step (the maximum of a running mean, optionally less the
running mean's own noise) with the σ under it."""

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


#: the trend :func:`window_noise` measures a running mean's noise about: a running mean this many
#: peak windows wide
NOISE_TREND_WINDOWS = 5


def running_mean(values: np.ndarray, width: int) -> np.ndarray:
    """The running mean of ``values`` (shape (n,)) over ``width`` samples, shape (n − width + 1,)."""
    return np.convolve(np.asarray(values, dtype=float), np.ones(width) / width, mode="valid")


def window_noise(rotation: np.ndarray, series: np.ndarray, window: float) -> float:
    """How loud ``series`` (shape (n,), any unit; τ in Pa for a shear step) is on the scale its peak
    is read at: the s.d. of its running mean over ``window`` rad (``rotation`` in rad, shape (n,);
    :func:`running_mean_width`) about a running mean :data:`NOISE_TREND_WINDOWS` times as wide,
    over the step after its rise (from where the running mean first reaches the median of its
    second half), so that the rise to the plateau does not count as noise. A real peak narrower
    than the trend counts partly as noise. Same unit as ``series``; 0 where less than the trend's
    width follows the rise."""
    width = running_mean_width(rotation, window)
    wide = NOISE_TREND_WINDOWS * width
    means = running_mean(series, width)
    if means.size < 2:
        return 0.0
    risen = np.flatnonzero(means >= np.median(means[means.size // 2:]))
    tail = np.asarray(series, dtype=float)[int(risen[0]) if risen.size else 0:]
    if tail.size < wide + width:
        return 0.0
    short, trend = running_mean(tail, width), running_mean(tail, wide)
    offset = (wide - width) // 2
    return float(np.std(short[offset:offset + trend.size] - trend))


def peak_noise_ratio(shear_steps: list, window: float) -> float:
    """The noise of a test's τ/σ in the peak window: :func:`window_noise` of each shear step's τ
    over its target σ, averaged over the steps (``shear_steps``: StepRecords), dimensionless. One
    figure for the test, because the steps share the cell that makes the noise; each step's own
    scatters (at quick, the correction by each step's own doubled C's seed s.d., by the test's
    mean it did not)."""
    values = [window_noise(s.rotation, np.asarray(s.shear_stress) / s.target_stress, window)
              for s in shear_steps if np.asarray(s.shear_stress).size]
    return float(np.mean(values)) if values else 0.0


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
    smooth = running_mean(tau, width)
    i = int(np.argmax(smooth))
    centre = i + width // 2
    position = float((rot[centre] - rot[0]) / span) if span > 0 else 1.0
    return float(smooth[i]), centre, position
