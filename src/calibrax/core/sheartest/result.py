"""The result of one shear test: each step's time series (:class:`StepRecord`), the provenance,
and :class:`ShearTestResult` with its peaks, preshears, densities, yield locus and warnings."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from calibrax.core.sheartest.peaks import (find_peak, peak_noise_ratio, preshear_drift, preshear_steady_part,
                                          stress_at_peak)
from calibrax.core.sheartest.physics import (BASE_SLIP_FRACTION, BASE_SPIN_SLIP_FRACTION, base_slip, inertial_number,
                                             locus_warning, rim_gap_warning, steady_base_load)
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.core.sheartest.steps import StepRecord
from calibrax.core.sheartest.yieldlocus import YieldLocus
from calibrax.errors import SimulationFailed

#: a step whose mean measured σ is below this fraction of its target lost the bed (the servo let the
#: head lift off): the simulation is a failure, not a result (seen: LIGGGHTS' PI servo at μr = 0)
LOST_BED_FRACTION = 0.5


@dataclass(frozen=True)
class Provenance:
    """Who made a result, and how."""

    backend: str
    engine_version: str
    spec_hash: str
    seed: int
    wall_time: float
    particle_count: int
    threads: int = 1
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def cpu_seconds(self) -> float:
        """The simulation's CPU time (s): the engine's own count where it keeps one (numba_dem's
        ``stage_cpu``, every thread's process time), else its wall time × ``threads`` (an engine run
        as a subprocess). Wall time alone misstates CPU: two threads halve it, a busy machine
        inflates it."""
        stages = self.extra.get("stage_cpu")
        if stages:
            return float(sum(stages.values()))
        return float(self.wall_time) * max(int(self.threads), 1)


@dataclass(frozen=True)
class ShearTestResult:
    """A whole shear test: the steps' time series and what is read off them.

    Arrays indexed by shear step k (shape (k,)): ``peak_shear_stress`` (Pa), ``peak_normal_stress``
    (σ measured at the peak: its mean over the peak's running-mean window, Pa; :func:`stress_at_peak`),
    ``target_normal_stress`` (Pa), ``peak_position`` (fraction of the
    window), ``bulk_density`` (after the preceding preshear, kg/m³), ``preshear_shear_stress``
    (steady τ of the preceding preshear, Pa), ``inertial_number``, ``preshear_rotation`` (how far
    the preceding preshear turned, rad) and ``preshear_drift`` (how far from steady it ended,
    :func:`preshear_drift`; NaN where it was shorter than two steady windows). The last two are
    empty in results stored before they existed.
    """

    steps: tuple[StepRecord, ...]
    peak_shear_stress: np.ndarray
    peak_normal_stress: np.ndarray
    target_normal_stress: np.ndarray
    peak_position: np.ndarray
    bulk_density: np.ndarray
    preshear_shear_stress: np.ndarray
    preshear_normal_stress: np.ndarray
    inertial_number: np.ndarray
    provenance: Provenance
    warnings: tuple[str, ...] = ()
    preshear_rotation: np.ndarray = field(default_factory=lambda: np.empty(0))
    preshear_drift: np.ndarray = field(default_factory=lambda: np.empty(0))
    conditioned_bulk_density: float = math.nan
    compression_stress: np.ndarray = field(default_factory=lambda: np.empty(0))
    compression_height: np.ndarray = field(default_factory=lambda: np.empty(0))

    @classmethod
    def from_steps(cls, spec: ShearCellSpec, steps: list[StepRecord], bulk_density: list[float],
                   provenance: Provenance, warnings: list[str] | None = None,
                   conditioned_bulk_density: float = math.nan,
                   compression_height: list[float] | None = None) -> "ShearTestResult":
        """Read peaks, preshear steady values and inertial numbers off the steps, the same way for
        every backend. ``bulk_density[k]`` is the bed's density after the k-th preshear (kg/m³);
        ``conditioned_bulk_density`` the poured bed's (kg/m³,
        :func:`~calibrax.core.sheartest.density.conditioned_bulk_density`); ``compression_height[i]``
        the bed's height at the i-th stress of ``procedure.compressibility_stresses`` (m)."""
        ramp = tuple(spec.procedure.compressibility_stresses)
        heights = list(compression_height or [])
        if len(heights) != len(ramp):
            raise SimulationFailed(f"the compressibility ramp has {len(ramp)} stresses but the backend returned "
                                   f"{len(heights)} bed heights", kind="invalid")
        warns = list(warnings or [])
        for k, s in enumerate(steps):
            if s.normal_stress.size and not np.mean(s.normal_stress) >= LOST_BED_FRACTION * s.target_stress:
                raise SimulationFailed(
                    f"the head lost the bed: {s.kind} step {k} held a mean σ of {np.mean(s.normal_stress):.0f} Pa "
                    f"against its target {s.target_stress:.0f} Pa (below {LOST_BED_FRACTION:.0%}); its peaks "
                    "would mean nothing", kind="invalid")
        shear = [s for s in steps if s.kind == "shear"]
        pre = [s for s in steps if s.kind == "preshear"]
        peaks, sig, pos, inert, tau_pre, sig_pre = [], [], [], [], [], []
        noise = peak_noise_ratio(shear, spec.procedure.peak_window) if spec.procedure.peak_noise_correction else 0.0
        for k, s in enumerate(shear):
            tau_p, i, where = find_peak(s.rotation, s.shear_stress, spec.procedure.peak_window)
            tau_p -= spec.procedure.peak_noise_correction * noise * s.target_stress
            peaks.append(tau_p)
            sig.append(stress_at_peak(s.rotation, s.normal_stress, spec.procedure.peak_window, i))
            pos.append(where)
            inert.append(inertial_number(spec, s.target_stress))
            if where > 0.95:
                warns.append(f"shear step {k} (σ = {s.target_stress:.0f} Pa): peak at the window's end "
                             f"({where:.2f}); the shear rotation may be too short")
        proc = spec.procedure
        pre_rot, drift = [], []
        for k, s in enumerate(pre):
            tail = preshear_steady_part(s.rotation, proc)
            tau_pre.append(float(np.mean(s.shear_stress[tail])) if s.shear_stress.size else float("nan"))
            sig_pre.append(float(np.mean(s.normal_stress[tail])) if s.normal_stress.size else float("nan"))
            pre_rot.append(float(s.rotation[-1]) if s.rotation.size else float("nan"))
            drift.append(preshear_drift(s.rotation, s.shear_stress, s.normal_stress, proc.steady_window))
        if proc.preshear_max_rotation is not None:
            unsteady = [k for k, d in enumerate(drift) if not d <= proc.steady_tolerance]
            if unsteady:
                warns.append(
                    f"{len(unsteady)} of {len(pre)} preshears ended before τ/σ was steady (preshear "
                    + ", ".join(f"{k}: {pre_rot[k]:.2f} rad, drift {drift[k]:.1%}" for k in unsteady)
                    + f"; criterion: ≤ {proc.steady_tolerance:.1%} between two windows of {proc.steady_window} rad, "
                    f"cap procedure.preshear_max_rotation = {proc.preshear_max_rotation} rad); raise the cap")
        slips = [base_slip(s, spec.procedure.rotation_rate) for s in shear]
        slipped = [(k, v) for k, v in enumerate(slips) if v >= BASE_SPIN_SLIP_FRACTION]
        load = steady_base_load(spec, shear, bulk_density)
        if slipped:
            worst = max(v for _, v in slipped)
            warns.append(f"the bed slid on the base: its bottom layer turned at up to {worst:.0%} of the head's rate "
                         f"in {len(slipped)} of {len(shear)} shear steps (≥ {BASE_SPIN_SLIP_FRACTION:.0%}), so τ "
                         "measures the base more than the powder; give the base (more, higher) ribs "
                         "(geometry.base_ribs, geometry.rib_height) or more friction (geometry.base_friction)")
        elif load >= BASE_SLIP_FRACTION and not any(np.isfinite(slips)):
            mu_base, _ = spec.effective_base_friction()
            warns.append(f"the bed slid on the base: the steady τ of the shear steps reached {load:.0%} of what the "
                         f"flat base (μ = {mu_base:.3g}) can hold, so τ measures the base's friction more than the "
                         "powder's strength; give the base ribs (geometry.base_ribs) or more friction "
                         "(geometry.base_friction)")
        wedge = rim_gap_warning(spec)
        if wedge is not None:
            warns.append(wedge)
        odd = locus_warning(np.asarray([s.target_stress for s in shear], float), np.asarray(peaks, float))
        if odd is not None:
            warns.append(odd)
        i_max = max(inert, default=0.0)
        if i_max > 1e-2:
            warns.append(f"inertial number up to {i_max:.1e} > 1e-2: the shear was not quasi-static; "
                         "lower procedure.rotation_rate")
        n = len(shear)
        return cls(
            steps=tuple(steps),
            peak_shear_stress=np.asarray(peaks, dtype=float),
            peak_normal_stress=np.asarray(sig, dtype=float),
            target_normal_stress=np.asarray([s.target_stress for s in shear], dtype=float),
            peak_position=np.asarray(pos, dtype=float),
            bulk_density=np.asarray(bulk_density[:n], dtype=float),
            preshear_shear_stress=np.asarray(tau_pre[:n], dtype=float),
            preshear_normal_stress=np.asarray(sig_pre[:n], dtype=float),
            inertial_number=np.asarray(inert, dtype=float),
            provenance=provenance,
            warnings=tuple(warns),
            preshear_rotation=np.asarray(pre_rot[:n], dtype=float),
            preshear_drift=np.asarray(drift[:n], dtype=float),
            conditioned_bulk_density=float(conditioned_bulk_density),
            compression_stress=np.asarray(ramp, dtype=float),
            compression_height=np.asarray(heights, dtype=float),
        )

    @property
    def compressibility(self) -> np.ndarray:
        """The compressibility at each stress of the ramp, %, shape (m,)
        (:func:`~calibrax.core.sheartest.density.compressibility_percent`); empty without a ramp."""
        from calibrax.core.sheartest.density import compressibility_percent

        return compressibility_percent(self.compression_height)

    @property
    def base_slip(self) -> np.ndarray:
        """Per shear step, the bottom layer's spin over the head's rate (:func:`base_slip`), shape
        (k,); NaN where the backend did not record it."""
        rate = self._rotation_rate()
        return np.asarray([base_slip(s, rate) for s in self.steps if s.kind == "shear"], dtype=float)

    def _rotation_rate(self) -> float:
        """The head's rotation rate, rad/s, read off the first step's time series."""
        for s in self.steps:
            if s.rotation.size >= 2 and s.time[-1] > s.time[0]:
                return float((s.rotation[-1] - s.rotation[0]) / (s.time[-1] - s.time[0]))
        return math.nan

    def is_finite(self) -> bool:
        """True when every peak and measured σ is a finite number."""
        return bool(np.all(np.isfinite(self.peak_shear_stress)) and np.all(np.isfinite(self.peak_normal_stress)))

    def yield_locus(self, against: Literal["target", "measured"] = "target") -> YieldLocus:
        """Fit the locus against the servo's target σ (the paper's way) or the σ measured at each peak."""
        sigma = self.target_normal_stress if against == "target" else self.peak_normal_stress
        return YieldLocus.fit(sigma, self.peak_shear_stress)
