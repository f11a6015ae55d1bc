"""The FT4's density measurements, read the same way off every backend's particles.

* **Conditioned bulk density** (CBD): the FT4 conditions the powder, splits the vessel at a fixed
  height, levels off what lies above and weighs what is left. Here: the poured bed, before the
  head touches it, split at :data:`SPLIT_HEIGHT_FRACTION` of its height; the particles' volume
  below the plane (each sphere cut exactly by it) over the vessel's volume below it. Counting cut
  spheres by their part below the plane, as levelling does on average, keeps the bed's rough top
  out of the measurement: at ``tiny`` (numba_dem, μs = 0.35) six seeds scattered by 8 kg/m³
  (0.5 %), against 16 kg/m³ for the density under the head after the preshear.
* **Compressibility**: the FT4 compresses the conditioned bed with a vented piston through a
  ramp of normal stresses and reports the volume's change in percent, on a sample of its own.
  Here the head, its blades retracted, compresses a copy of the poured bed through
  ``procedure.compressibility_stresses`` (the shear test runs on the original) and the result
  carries the bed's height at each; the compressibility at σ is the volume lost since the ramp's first stress,
  100 (1 − h(σ)/h(σ₁)) %. Measured from the first stress of the same run, it does not carry the
  bias a small cell's walls give the absolute density (they cancel in the ratio).
"""

from __future__ import annotations

import math

import numpy as np

#: the vessel is split at this fraction of the poured bed's height (its top: :func:`bed_top`);
#: what lies above is levelled off. Low enough that the rough top (about a diameter) lies above
#: the plane at every preset (``tiny``'s bed is 8 diameters high)
SPLIT_HEIGHT_FRACTION = 0.75
#: the bed's top is the mean top of this fraction of the highest particles
BED_TOP_FRACTION = 0.05


def bed_top(z: np.ndarray, radius: np.ndarray) -> float:
    """Height of a bed's surface, m: the mean top (z + r) of the :data:`BED_TOP_FRACTION` highest
    particles. ``z``, ``radius``: particle centres' heights above the base and radii, shape (n,), m."""
    top = np.asarray(z, float) + np.asarray(radius, float)
    k = max(1, int(BED_TOP_FRACTION * top.size))
    return float(np.mean(np.sort(top)[-k:]))


def volume_below(z: np.ndarray, radius: np.ndarray, plane: float) -> np.ndarray:
    """Each sphere's volume below the horizontal plane at height ``plane`` (m), m³, shape (n,):
    the whole sphere, none of it, or the spherical cap the plane cuts off."""
    r = np.asarray(radius, float)
    cap = np.clip(plane - (np.asarray(z, float) - r), 0.0, 2.0 * r)
    return math.pi * cap**2 * (3.0 * r - cap) / 3.0


def conditioned_bulk_density(z: np.ndarray, radius: np.ndarray, particle_density: float | np.ndarray,
                             cross_section: float) -> float:
    """The conditioned bulk density of a poured bed, kg/m³ (see the module's docstring).

    Args:
        z, radius: particle centres' heights above the base and radii, shape (n,), m.
        particle_density: the particles' material density, kg/m³ (scalar or shape (n,)).
        cross_section: the horizontal area the particles fill, m²: π R² of the vessel (a sector's:
            :attr:`~calibrax.core.sheartest.spec.ShearCellSpec.bed_cross_section`).
    """
    plane = SPLIT_HEIGHT_FRACTION * bed_top(z, radius)
    mass = float(np.sum(np.asarray(particle_density, float) * volume_below(z, radius, plane)))
    return mass / (cross_section * plane)


def compressibility_percent(heights: np.ndarray) -> np.ndarray:
    """The FT4's compressibility at each stress of a ramp, %, shape (m,): 100 (1 − h/h₀), with
    ``heights`` the bed's height at each stress, m, shape (m,), and h₀ the first."""
    h = np.asarray(heights, float)
    if h.size == 0:
        return h
    return 100.0 * (1.0 - h / h[0])


def rebase_compressibility(percent: np.ndarray) -> np.ndarray:
    """An FT4 compressibility series measured from the conditioned volume (%, shape (m,)) measured
    from its first stress instead, as calibrax reads a simulation's: the volumes are V/V_c =
    1 − c/100, so the change since the first stress is 100 (1 − (1 − c/100)/(1 − c₀/100))."""
    c = np.asarray(percent, float) / 100.0
    if c.size == 0:
        return c
    return 100.0 * (1.0 - (1.0 - c) / (1.0 - c[0]))
