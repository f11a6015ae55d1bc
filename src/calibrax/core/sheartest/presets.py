"""The procedure presets (the paper's, ASTM D7891's) and the fidelity presets (cell size, time step,
rotation and sampling: ``paper``, ``converged``, ``quick``, ``tiny``)."""

from __future__ import annotations

from typing import Any

#: Procedure presets: the paper's, the FT4 standard shear test of ASTM D7891 (9 kPa preshear), and
#: the FT4's low-stress standard (3 kPa preshear; shear steps at 2.0, 1.75, 1.5, 1.25 and 1.0 kPa as
#: Freeman Technology's 3 kPa method sets them: check them against your instrument's method file).
#: The low-stress test is where a cohesive powder differs most: the Bond number of a powder
#: (:mod:`calibrax.core.sheartest.cohesion`, taken at 15 kPa) is five times larger at 3 kPa.
#: Each is the Procedure fields it sets (the stresses); a fidelity preset sets the rest.
PROCEDURES: dict[str, dict[str, Any]] = {
    "paper": {"preshear_stress": 15.0e3, "shear_stresses": (9.0e3, 8.0e3, 7.0e3, 6.0e3)},
    "astm_d7891": {"preshear_stress": 9.0e3, "shear_stresses": (7.0e3, 6.0e3, 5.0e3, 4.0e3, 3.0e3)},
    "ft4_3kpa": {"preshear_stress": 3.0e3, "shear_stresses": (2.0e3, 1.75e3, 1.5e3, 1.25e3, 1.0e3)},
}

#: Fidelity presets: cell size in particle diameters (H/D = 0.88 as the paper's 12k…200k beds),
#: time-step fraction, rotation and sampling, and as many one-diameter base ribs as the head has blades.
#: ``quick`` and ``tiny`` step at 0.15 Δt_crit: at 0.20, with the ribbed base and friction ≥ 0.9 on
#: particles or base, a particle's rotation went unstable (numba_dem, quick, μs = 0.9, seed 1: a
#: particle touching a rib oscillated with a sign flip every step, ×2–3 per step, and escaped;
#: LIGGGHTS lost atoms at tiny); sticking contacts stack the tangential and rolling springs' rotational
#: stiffness, and a rib adds one more wall contact, the stiffest kind (R* = r) ``paper`` is the reference paper's converged setting;
#: ``quick`` fits a 2-core machine; ``tiny`` is for tests and ``make run``.
#: ``converged`` is ``paper``'s cell (18 blades and ribs) taken to 46 per diameter the paper's way (the
#: vessel grows, the particles stay) as numba_dem's 1/9 periodic sector at ``quick``'s inertial
#: number, its shear steps branched from one presheared bed and its peak read with the noise
#: correction: about 42 CPU-minutes a test where ``paper`` is tens of CPU-hours. At 34 per diameter
#: (10 CPU-minutes) τ/σ, C and AIF agree with 46's but the bulk density reads 3.0 % under it, beyond
#: the 2 % the convergence study's rule allows, so the finest measured cell is the preset; its
#: density is still rising with size (docs/explanation/sector.md, "The converged preset").
#: Only a backend with rotational periodicity (numba_dem) runs it.
#: A preset may state ``sector`` (k of ``geometry.sector``; 1, the full cell, when absent) and
#: ``rim_gap_d`` (the head's radius is D/2 − rim_gap_d·d; 0.48 D when absent).
#: Every preset preshears as the FT4 does, until τ/σ is steady (two windows of 0.1 rad within 5 %;
#: at least 0.3 rad, at most 1 rad): the former fixed preshears of 0.12–0.15 rad ended inside the
#: transient (at tiny τ/σ fell from 0.94 to a steady 0.55 over the first 0.45 rad of one preshear),
#: and with the blades riding on the bed's top (see INSERTION_STRESS_FRACTION) that made most of the
#: seed scatter. The shear windows of 0.3 rad hold the peaks that 0.12 rad cut off 
#: (docs/explanation/seed-noise.md).
#: ``quick``'s inertial number at the 15 kPa preshear (5 rad/s at 12 per diameter, Table 1 density;
#: :func:`calibrax.core.sheartest.physics.inertial_number`), which ``converged`` keeps at its size
QUICK_INERTIAL_NUMBER = 0.0015455701860478547
#: The gap between the head's rim and the vessel wall, in particle diameters, of a preset that
#: states ``rim_gap_d`` (``paper``, ``converged``); the others set the head's radius to 0.48 D, a gap
#: of 0.02 D (0.18 d at ``tiny``, 0.24 d at ``quick``). 0.02 D at 34 and 46 per diameter is 0.68 and
#: 0.92 d, where a particle wedges between a blade's edge and a frictional wall and τ measures the
#: wedge (docs/explanation/sector.md, "A frictional wall and the rim gap"); 0.24 d, ``quick``'s, is
#: under one radius, so nothing enters it.
RIM_GAP_D = 0.24
STEADY_PRESHEAR = {"preshear_rotation": 0.30, "preshear_max_rotation": 1.0, "steady_window": 0.1,
                   "steady_tolerance": 0.05}
FIDELITY_PRESETS: dict[str, dict[str, Any]] = {
    "paper": {
        "particles_per_diameter": 34.0, "height_ratio": 0.88, "blade_count": 18, "blade_height_d": 2.0, "base_ribs": 18,
        "rim_gap_d": RIM_GAP_D,
        "procedure": {"rotation_rate": 0.5, **STEADY_PRESHEAR, "shear_rotation": 0.30,
                      "settle_time": 0.02, "peak_window": 0.01},
        "numerics": {"dt_fraction": 0.05, "sample_interval": 2.0e-4},
    },
    "converged": {
        "particles_per_diameter": 46.0, "height_ratio": 0.88, "blade_count": 18, "blade_height_d": 2.0, "base_ribs": 18,
        "rim_gap_d": RIM_GAP_D, "sector": 9,
        "procedure": {"inertial_number": QUICK_INERTIAL_NUMBER, **STEADY_PRESHEAR, "shear_rotation": 0.30,
                      "settle_time": 0.005, "peak_window": 0.03, "branches": True, "peak_noise_correction": 2.5},
        "numerics": {"dt_fraction": 0.15, "sample_interval": 2.0e-4},
    },
    "quick": {
        "particles_per_diameter": 12.0, "height_ratio": 0.88, "blade_count": 12, "blade_height_d": 2.0, "base_ribs": 12,
        "procedure": {"rotation_rate": 5.0, **STEADY_PRESHEAR, "shear_rotation": 0.30,
                      "settle_time": 0.005, "peak_window": 0.03},
        "numerics": {"dt_fraction": 0.15, "sample_interval": 2.0e-4},
    },
    "tiny": {
        "particles_per_diameter": 9.0, "height_ratio": 0.88, "blade_count": 8, "blade_height_d": 2.0, "base_ribs": 8,
        "procedure": {"rotation_rate": 6.0, **STEADY_PRESHEAR, "shear_rotation": 0.30,
                      "settle_time": 0.004, "peak_window": 0.03},
        "numerics": {"dt_fraction": 0.15, "sample_interval": 2.0e-4},
    },
}
