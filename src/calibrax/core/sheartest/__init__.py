"""The FT4 cylindrical shear test as one backend-neutral spec, and its result.

``ShearCellSpec`` describes geometry, particles, material, procedure and numerics in SI units
(Pa, m, s, rad, kg). Every backend (numba_dem, LIGGGHTS, YADE) simulates the *same* spec and
returns a ``ShearTestResult`` whose peaks are found by the *same* function here, so that
backends can be compared like with like.

The package is split by job, and every public name is importable from here:

* :mod:`~calibrax.core.sheartest.spec`: the spec's dataclasses (Table 1 material and the paper's
  procedure by default);
* :mod:`~calibrax.core.sheartest.validation`: the spec's checks, each error naming its field;
* :mod:`~calibrax.core.sheartest.presets`: the procedure and fidelity presets;
* :mod:`~calibrax.core.sheartest.stages`: the insertion and consolidation rules every backend applies;
* :mod:`~calibrax.core.sheartest.physics`: Δt_crit, τ from torque, the inertial number, the base;
* :mod:`~calibrax.core.sheartest.peaks`: the preshear's steady part and a shear step's peak;
* :mod:`~calibrax.core.sheartest.result`: the result type, its peaks, warnings and failures.
* :mod:`~calibrax.core.sheartest.yieldlocus`: the yield locus and its Mohr analysis;
* :mod:`~calibrax.core.sheartest.density`: the conditioned bulk density and the compressibility;
* :mod:`~calibrax.core.sheartest.packing`, :mod:`~calibrax.core.sheartest.servo`: the initial
  packing and the head's servo gains every backend starts from;
* :mod:`~calibrax.core.sheartest.facets`: radial plates for backends with mesh walls;
* :mod:`~calibrax.core.sheartest.analytic`, :mod:`~calibrax.core.sheartest.verification`: the
  analytic references of the contact law and the contract of a backend's checks against them.
"""

from __future__ import annotations

from calibrax.core.sheartest.density import (SPLIT_HEIGHT_FRACTION, bed_top, compressibility_percent,
                                             conditioned_bulk_density, rebase_compressibility, volume_below)
from calibrax.core.sheartest.peaks import (FIXED_PRESHEAR_STEADY_FRACTION, find_peak, preshear_drift,
                                           preshear_steady_part, running_mean_width, steady_schedule,
                                           steady_window_samples, stress_at_peak)
from calibrax.core.sheartest.physics import (BASE_SLIP_FRACTION, BASE_SPIN_SLIP_FRACTION, GRAVITY, base_layer_bounds,
                                             base_shear_capacity, base_slip, inertial_number,
                                             layer_spin, locus_warning, rim_gap_warning, shear_stress_from_torque,
                                             steady_base_load)
from calibrax.core.sheartest.presets import FIDELITY_PRESETS, PROCEDURES, STEADY_PRESHEAR
from calibrax.core.sheartest.result import LOST_BED_FRACTION, Provenance, ShearTestResult
from calibrax.core.sheartest.steps import StepRecord
from calibrax.core.sheartest.timestep import critical_time_step
from calibrax.core.sheartest.spec import Geometry, Material, Numerics, Procedure, ShearCellSpec, SizeDistribution
from calibrax.core.sheartest.stages import (APPROACH_CLEARANCE, APPROACH_SPEED, COMPRESSION_MAX_TIME,
                                            COMPRESSION_MIN_TIME, CONSOLIDATION_LIMIT_FACTOR,
                                            CONSOLIDATION_LIMIT_ROTATION, INSERTION_FRICTION, INSERTION_STRESS_FRACTION,
                                            INSERTION_TIME_FACTOR, INSERTION_TOLERANCE_RADII, MAX_SPEED, POUR_FRICTION,
                                            POUR_GRAVITY, POUR_SPEED, UNLOAD_MAX_ROTATION, insertion_time_limit)
from calibrax.core.sheartest.yieldlocus import MohrAnalysis, YieldLocus

__all__ = [
    "Material", "SizeDistribution", "Geometry", "Procedure", "Numerics", "ShearCellSpec",
    "StepRecord", "Provenance", "ShearTestResult", "YieldLocus", "MohrAnalysis", "LOST_BED_FRACTION",
    "critical_time_step", "find_peak", "shear_stress_from_torque", "inertial_number",
    "base_shear_capacity", "steady_base_load", "BASE_SLIP_FRACTION", "BASE_SPIN_SLIP_FRACTION",
    "base_slip", "base_layer_bounds", "layer_spin", "locus_warning", "rim_gap_warning", "GRAVITY", "PROCEDURES", "FIDELITY_PRESETS",
    "STEADY_PRESHEAR", "preshear_drift", "preshear_steady_part", "FIXED_PRESHEAR_STEADY_FRACTION",
    "steady_window_samples", "running_mean_width", "stress_at_peak", "steady_schedule",
    "INSERTION_STRESS_FRACTION", "INSERTION_FRICTION", "INSERTION_TIME_FACTOR", "INSERTION_TOLERANCE_RADII",
    "CONSOLIDATION_LIMIT_FACTOR", "CONSOLIDATION_LIMIT_ROTATION", "insertion_time_limit", "POUR_FRICTION",
    "POUR_GRAVITY", "POUR_SPEED", "APPROACH_SPEED", "APPROACH_CLEARANCE", "UNLOAD_MAX_ROTATION", "MAX_SPEED",
    "COMPRESSION_MIN_TIME", "COMPRESSION_MAX_TIME", "SPLIT_HEIGHT_FRACTION", "bed_top", "compressibility_percent",
    "conditioned_bulk_density",
    "rebase_compressibility", "volume_below",
]
