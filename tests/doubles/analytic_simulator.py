"""TEST DOUBLE — an analytic stand-in for a DEM backend, for unit and integration tests of the
core only (the campaign loop, the store, the CLI). It is not a simulator of anything.

Registered as simulator ``analytic_double`` through ``CALIBRAX_PLUGINS=tests.doubles.analytic_simulator``.
Its yield locus is a known function of (E, μs):

    AIF = atan(0.25 + 0.7 μs),   C = 300 Pa + 400 Pa · (log10(E / Pa) − 10) + 200 Pa · μs

at the ``tiny`` cell (9 particles per diameter); a finer cell shifts it (a fidelity bias, for
multi-fidelity campaigns): C by −3000 Pa · g and tan(AIF) by −2 g, g = 1/9 − 1/(particles per
diameter) (``quick``: −83 Pa and −0.056, what μs ≈ 0.08 lower gives at tiny). Each shear step's
τ curve rises to its peak at 0.05 rad and softens after it. The diagnosis's
effects act on it in known ways: lateral wall friction w multiplies every τ by (1 + 0.8 w) and the
bulk density by (1 − 0.1 w); rolling friction μr adds 0.3 (μr − 0.5) to tan(AIF); cohesion k adds k/10⁴ Pa to C (k in J/m³); a size distribution of
width s multiplies the bulk density by (1 + 0.15 s).
Environment knobs for fault and scheduling tests:

* ``CALIBRAX_DOUBLE_SLEEP``: seconds per simulation, or ``A-B`` for a duration drawn uniformly in
  [A, B] from the simulation's seed (uneven durations);
* ``CALIBRAX_DOUBLE_NOISE``: relative s.d. of seed noise on each peak and preshear (a fifth of it on
  the bulk density), drawn from the simulation's seed (default 0: deterministic);
* ``CALIBRAX_DOUBLE_FAULT=KIND:MU``: above μs = MU, ``fail`` (raise SimulationFailed), ``crash``
  (the process aborts), ``hang`` (sleeps for an hour) or ``nan`` (returns NaN peaks).

Every completed simulation appends a line to ``completions.log`` in its work folder.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import numpy as np

from calibrax import hookimpl
from calibrax.core.sheartest import Provenance, ShearCellSpec, ShearTestResult, StepRecord
from calibrax.errors import SimulationFailed


#: d tan(AIF) / d μr: rolling friction steepens the locus, from Table 1's μr = 0.5
ROLLING_SLOPE = 0.3


def true_locus(youngs_modulus: float, sliding_friction: float) -> tuple[float, float]:
    """(C in Pa, AIF in degrees) of the double at (E, μs)."""
    aif = math.degrees(math.atan(0.25 + 0.7 * sliding_friction))
    c = 300.0 + 400.0 * (math.log10(youngs_modulus) - 10.0) + 200.0 * sliding_friction
    return c, aif


def fidelity_bias(particles_per_diameter: float) -> tuple[float, float]:
    """(ΔC in Pa, Δtan(AIF)) of a cell of ``particles_per_diameter`` against ``tiny``'s 9."""
    g = 1.0 / 9.0 - 1.0 / particles_per_diameter
    return -3000.0 * g, -2.0 * g


def curve(rotation: np.ndarray, peak: float, residual: float = 0.85) -> np.ndarray:
    """τ(θ): rises to ``peak`` at θ = 0.05 rad, then softens towards ``residual`` × peak."""
    theta_p = 0.05
    rise = peak * (rotation / theta_p) * np.exp(1.0 - rotation / theta_p)
    return np.where(rotation <= theta_p, rise, residual * peak + (1 - residual) * rise)


class AnalyticDoubleSimulator:
    """TEST DOUBLE of a Simulator with a known, deterministic yield locus."""

    name = "analytic_double"

    def capabilities(self) -> frozenset[str]:
        return frozenset({"wall_friction", "size_distribution", "cohesion", "base_ribs", "rolling_friction"})

    def version(self) -> str:
        return "analytic-double 1.0"

    def simulate(self, spec: ShearCellSpec, workdir: Path) -> ShearTestResult:
        t0 = time.perf_counter()
        m = spec.material
        sleep = os.environ.get("CALIBRAX_DOUBLE_SLEEP", "0")
        if "-" in sleep:
            low, high = (float(v) for v in sleep.split("-"))
            time.sleep(np.random.default_rng(spec.numerics.seed).uniform(low, high))
        else:
            time.sleep(float(sleep))
        fault, _, threshold = os.environ.get("CALIBRAX_DOUBLE_FAULT", "").partition(":")
        faulty = bool(fault) and m.sliding_friction > float(threshold)
        if faulty and fault == "fail":
            raise SimulationFailed(f"double told to fail at μs = {m.sliding_friction:.3f}", "double log tail",
                                   kind="unstable")
        if faulty and fault == "crash":
            os.abort()
        if faulty and fault == "hang":
            time.sleep(3600)
        c, aif = true_locus(m.youngs_modulus, m.sliding_friction)
        if faulty and fault == "nan":
            c = float("nan")
        c += m.cohesion_energy_density / 1e4 + 1500.0 * m.bond_number  # Pa: the cohesion effect, by k or by Bond number
        bias_c, bias_slope = fidelity_bias(spec.particles_per_diameter)
        c += bias_c
        slope = math.tan(math.radians(aif)) + bias_slope + ROLLING_SLOPE * (m.rolling_friction - 0.5)
        wall = 1.0 + 0.8 * spec.geometry.wall_friction
        packing = (1.0 - 0.1 * spec.geometry.wall_friction) * (1.0 + 0.15 * spec.size_distribution.sigma_log)
        noise = float(os.environ.get("CALIBRAX_DOUBLE_NOISE", "0"))
        rng = np.random.default_rng(spec.numerics.seed)
        p = spec.procedure
        steps, density = [], []
        t = 0.0
        for sigma in p.shear_stresses:
            for kind, target, span in (("preshear", p.preshear_stress, p.preshear_rotation),
                                       ("shear", sigma, p.shear_rotation)):
                rot = np.linspace(0.0, span, 201)
                peak = (c + target * slope) * wall * (1.0 + noise * rng.standard_normal())
                tau = curve(rot, peak) if kind == "shear" else np.full(rot.size, peak)
                times = t + rot / p.rotation_rate
                t = float(times[-1])
                steps.append(StepRecord(kind, target, times, rot, tau, np.full(rot.size, target),
                                        np.full(rot.size, spec.geometry.fill_height)))
            density.append(0.6 * m.density * packing * (1.0 + noise / 5 * rng.standard_normal()))
        prov = Provenance(self.name, self.version(), spec.spec_hash(), spec.numerics.seed,
                          time.perf_counter() - t0, spec.particle_count)
        result = ShearTestResult.from_steps(spec, steps, density, prov)
        with open(Path(workdir) / "completions.log", "a") as log:
            log.write(f"completed E={m.youngs_modulus} mu={m.sliding_friction} seed={spec.numerics.seed} "
                      f"slurm_job={os.environ.get('SLURM_JOB_ID', '-')}\n")
        return result


@hookimpl
def calibrax_simulators() -> list[type]:
    return [AnalyticDoubleSimulator]
