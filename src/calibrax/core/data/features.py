"""What a shear test is compared by: named features, read the same way off a simulation and off an
experiment, each with a unit, a meaning and a spread.

Every consumer (metrics, the diagnosis, reports, the noise tables) reads features from here, and
every backend is read through it, so that "the peak τ/σ at 9 kPa" means one thing everywhere.

Names. Features of one shear step end in the step's target σ in kPa: ``peak_tau_9kPa``,
``peak_ratio_7.5kPa``; features of the preshear before that step use the same suffix
(``preshear_ratio_9kPa``); whole-test features have none (``cohesion``, ``bulk_density``).

Spread. :func:`summarise` turns several samples of a feature (seeds of a simulation, replicates of
an experiment) into a mean, a sample standard deviation and a count: the seed-to-seed spread for
simulations, the replicate-to-replicate spread for an experiment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterable

import numpy as np

from calibrax.core.sheartest.density import rebase_compressibility
from calibrax.core.sheartest.yieldlocus import YieldLocus

if TYPE_CHECKING:  # pragma: no cover
    from calibrax.core.data.experiment import Experiment
    from calibrax.core.sheartest.result import ShearTestResult

__all__ = ["step_mean", "feature_stress", "FeatureDef", "FEATURES", "CurveShape", "curve_shape", "step_suffix",
           "feature_def", "result_features", "experiment_features", "FeatureSummary", "summarise", "STILL_RISING_POSITION"]


@dataclass(frozen=True)
class FeatureDef:
    """One kind of feature: its stem (the name without the step suffix), unit, meaning, and whether
    it is given per shear step."""

    stem: str
    unit: str
    doc: str
    per_step: bool


#: every feature calibrax reads off a shear test
FEATURES: dict[str, FeatureDef] = {f.stem: f for f in (
    FeatureDef("peak_tau", "Pa", "peak shear stress of the shear step (running mean of width "
               "procedure.peak_window); the yield locus is fitted to these", True),
    FeatureDef("peak_ratio", "1", "τ_peak over the normal stress measured at the peak (the target σ where "
               "the experiment did not record it): the step's friction coefficient at failure, far steadier "
               "across seeds than τ_peak itself because τ and σ swing together", True),
    FeatureDef("shear_end_ratio", "1", "mean τ over mean σ in the last quarter of the shear step's rotation: "
               "the post-peak (residual, near steady) friction of the step", True),
    FeatureDef("preshear_ratio", "1", "steady τ/σ of the preshear before the step (its rotation after the "
               "first steady-state window, or the last 40 % of a fixed preshear; sheartest.preshear_steady_part): "
               "the critical-state friction at the preshear stress", True),
    FeatureDef("initial_slope", "1/rad", "slope of τ/σ_target against rotation over the first third of "
               "the rise to the peak (how stiffly the bed takes up shear)", True),
    FeatureDef("curvature", "1", "c of y = a + b u + c u², fitted to the rise to the peak in normalised "
               "units (u = θ/θ_peak, y = τ/τ_peak): 0 for a linear rise, < 0 concave (the paper's "
               "simulated curves), > 0 convex; NaN when the curve is still rising at the window's end", True),
    FeatureDef("peak_rotation", "rad", "head rotation from the step's start to its peak (shear "
               "displacement in the instrument's angular units); NaN when still rising", True),
    FeatureDef("peak_prominence", "1", "(τ_peak − τ_end)/σ_target with τ_end the mean τ over the last "
               "quarter of the rotation: how clear the peak is; NaN when still rising", True),
    FeatureDef("softening", "1/rad", "slope of τ/σ_target against rotation from the peak to the window's "
               "end (< 0: post-peak softening); NaN when still rising", True),
    FeatureDef("still_rising", "1", "1 when τ was still rising at the end of the step's window (its peak "
               "lies in the last 5 % of the rotation: the window was too short to pass a peak), else 0", True),
    FeatureDef("cohesion", "Pa", "C of τ = C + σ tan(AIF) fitted to the peaks against the target σ (the "
               "paper's way)", False),
    FeatureDef("aif", "deg", "angle of internal friction, atan of the slope of that fit", False),
    FeatureDef("cohesion_measured", "Pa", "C fitted against the σ measured at each peak", False),
    FeatureDef("aif_measured", "deg", "AIF fitted against the σ measured at each peak", False),
    FeatureDef("bulk_density", "kg/m³", "bulk density after the first preshear, at the preshear stress "
               "(what the FT4 compressibility test measures at that stress)", False),
    FeatureDef("conditioned_bulk_density", "kg/m³", "the FT4's conditioned bulk density: the poured bed, before "
               "any load, split at 3/4 of its height and levelled (sheartest.density); where a size distribution "
               "and cohesion show most", False),
    FeatureDef("compressibility", "%", "the FT4 compressibility test: the bed's volume lost between the ramp's "
               "first stress and the stress in the suffix (procedure.compressibility_stresses; an experiment's "
               "series, measured from the conditioned volume, is rebased to its own first stress)", True),
)}

#: a step whose peak lies beyond this fraction of its rotation is still rising (see ``still_rising``)
STILL_RISING_POSITION = 0.95
#: the rise's first part that ``initial_slope`` is fitted to, and the tail that ``*_end`` reads
INITIAL_PART, END_PART = 1.0 / 3.0, 0.25


def step_suffix(sigma_pa: float) -> str:
    """The name suffix of a step at target σ (Pa): ``9000 → "9kPa"``, ``7500 → "7.5kPa"``."""
    return f"{round(sigma_pa / 1000.0, 3):g}kPa"


def feature_stress(name: str) -> float:
    """The normal stress in a feature's suffix, Pa (``"compressibility_7.5kPa"`` → 7500.0);
    ValueError if it has none."""
    return float(name.rsplit("_", 1)[1].removesuffix("kPa")) * 1000.0


def feature_def(name: str) -> FeatureDef:
    """The definition of a feature name (with or without its step suffix); KeyError if unknown."""
    stem = name
    if name.endswith("kPa") and "_" in name:
        stem = name.rsplit("_", 1)[0]
    return FEATURES[stem]


@dataclass(frozen=True)
class CurveShape:
    """The shape features of one τ curve (see :data:`FEATURES` for each)."""

    peak_tau: float
    peak_index: int
    initial_slope: float
    curvature: float
    peak_rotation: float
    peak_prominence: float
    softening: float
    end_ratio_tau: float
    still_rising: bool


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    if x.size < 2 or np.ptp(x) <= 0:
        return math.nan
    return float(np.polyfit(x, y, 1)[0])


def curve_shape(rotation: np.ndarray, shear_stress: np.ndarray, target_stress: float,
                peak_window: float) -> CurveShape:
    """Read the shape of one shear step's τ curve.

    Args:
        rotation: head rotation since the step's start, shape (n,), rad, increasing.
        shear_stress: τ, shape (n,), Pa.
        target_stress: the step's target σ, Pa (the normaliser of slopes and prominence).
        peak_window: width of the running mean the peak is taken from, rad.

    A curve whose peak lies in the last 5 % of its rotation is flagged ``still_rising`` and gets no
    peak shape (curvature, peak rotation, prominence and softening are NaN); its ``peak_tau`` is
    still its largest running mean, which is what an FT4 reports as the peak.
    """
    from calibrax.core.sheartest.peaks import find_peak

    rot = np.asarray(rotation, dtype=float)
    tau = np.asarray(shear_stress, dtype=float)
    nan = math.nan
    if rot.size < 4:
        return CurveShape(nan, -1, nan, nan, nan, nan, nan, nan, True)
    tau_p, i, position = find_peak(rot, tau, peak_window)
    y = tau / target_stress
    span = rot[-1] - rot[0]
    tail = rot >= rot[-1] - END_PART * span
    end_tau = float(np.mean(tau[tail]))
    rising = (rot[:i + 1] - rot[0])
    first = rising <= INITIAL_PART * max(rising[-1], 1e-300)
    initial = _slope(rot[:i + 1][first], y[:i + 1][first]) if i >= 1 else nan
    still = bool(position > STILL_RISING_POSITION)
    if still:
        return CurveShape(tau_p, i, initial, nan, nan, nan, nan, end_tau, True)
    curvature = nan
    if i >= 3 and rising[-1] > 0:
        u = rising / rising[-1]
        curvature = float(np.polyfit(u, tau[:i + 1] / tau_p, 2)[0])
    prominence = (tau_p - end_tau) / target_stress
    softening = _slope(rot[i:], y[i:])
    return CurveShape(tau_p, i, initial, curvature, float(rot[i] - rot[0]), float(prominence), softening,
                      end_tau, False)


def _locus(sigma: np.ndarray, tau: np.ndarray, prefix: str = "") -> dict[str, float]:
    ok = np.isfinite(sigma) & np.isfinite(tau)
    if np.unique(sigma[ok]).size < 2:
        return {}
    fit = YieldLocus.fit(sigma[ok], tau[ok])
    return {f"cohesion{prefix}": fit.cohesion, f"aif{prefix}": fit.aif_deg}


def result_features(result: "ShearTestResult", peak_window: float = 0.015) -> dict[str, float]:
    """Every feature of one simulated shear test.

    Args:
        result: the test.
        peak_window: the procedure's peak window, rad (``spec.procedure.peak_window``), for the
            curve-shape features (the peaks themselves are the result's own).

    Returns:
        {feature name: value in the unit of :data:`FEATURES`}.
    """
    out: dict[str, float] = {}
    shear = [s for s in result.steps if s.kind == "shear"]
    for k, step in enumerate(shear):
        sfx = step_suffix(step.target_stress)
        shape = curve_shape(step.rotation, step.shear_stress, step.target_stress, peak_window)
        out[f"peak_tau_{sfx}"] = float(result.peak_shear_stress[k])
        sigma_peak = float(result.peak_normal_stress[k])
        out[f"peak_ratio_{sfx}"] = float(result.peak_shear_stress[k]) / sigma_peak if sigma_peak > 0 else math.nan
        tail = step.rotation >= step.rotation[-1] - END_PART * (step.rotation[-1] - step.rotation[0])
        out[f"shear_end_ratio_{sfx}"] = float(np.mean(step.shear_stress[tail]) / np.mean(step.normal_stress[tail]))
        if k < len(result.preshear_shear_stress):
            out[f"preshear_ratio_{sfx}"] = float(result.preshear_shear_stress[k] / result.preshear_normal_stress[k])
        out.update(_shape_features(shape, sfx))
    out.update(_locus(result.target_normal_stress, result.peak_shear_stress))
    out.update(_locus(result.peak_normal_stress, result.peak_shear_stress, "_measured"))
    if result.bulk_density.size:
        out["bulk_density"] = float(result.bulk_density[0])
    out.update(_density_features(result.conditioned_bulk_density, result.compression_stress,
                                 result.compressibility))
    return out


def _density_features(conditioned: float, ramp_stress: np.ndarray, compressibility: np.ndarray) -> dict[str, float]:
    """``conditioned_bulk_density`` (kg/m³) where finite, and ``compressibility_<σ>`` (%) at every
    stress of the ramp after its first (the reference, 0 by definition); ``ramp_stress`` Pa and
    ``compressibility`` % measured from the first stress, both shape (m,)."""
    out = {"conditioned_bulk_density": float(conditioned)} if math.isfinite(conditioned) else {}
    for sigma, pct in list(zip(ramp_stress, compressibility))[1:]:
        out[f"compressibility_{step_suffix(float(sigma))}"] = float(pct)
    return out


def _shape_features(shape: CurveShape, sfx: str) -> dict[str, float]:
    return {f"initial_slope_{sfx}": shape.initial_slope, f"curvature_{sfx}": shape.curvature,
            f"peak_rotation_{sfx}": shape.peak_rotation, f"peak_prominence_{sfx}": shape.peak_prominence,
            f"softening_{sfx}": shape.softening, f"still_rising_{sfx}": float(shape.still_rising)}


def experiment_features(experiment: "Experiment", peak_window: float = 0.015) -> dict[int, dict[str, float]]:
    """The features of each replicate of an experiment, as far as its data go.

    Peaks give ``peak_tau``, ``cohesion`` and ``aif``; the σ measured at each peak (optional column)
    gives ``peak_ratio`` against it and ``cohesion_measured``/``aif_measured`` (without it,
    ``peak_ratio`` is against the target σ, which an FT4 holds within a few per cent); preshear
    columns give ``preshear_ratio``; a bulk density column gives ``bulk_density``; τ curves give the
    shape features and ``shear_end_ratio`` (over the target σ); a conditioned bulk density gives
    ``conditioned_bulk_density``, and a compressibility series, rebased to its first stress
    (:func:`~calibrax.core.sheartest.density.rebase_compressibility`), ``compressibility``.

    Args:
        experiment: the measured data.
        peak_window: running-mean width for peaks read off curves, rad.

    Returns:
        {replicate id: {feature name: value}}.
    """
    out: dict[int, dict[str, float]] = {}
    e = experiment
    for rep in e.replicates:
        m = e.replicate == rep
        sig, tau = e.normal_stress[m], e.peak_shear_stress[m]
        measured = e.measured_normal_stress[m]
        f: dict[str, float] = {}
        for j in range(sig.size):
            sfx = step_suffix(sig[j])
            f[f"peak_tau_{sfx}"] = float(tau[j])
            denom = measured[j] if np.isfinite(measured[j]) and measured[j] > 0 else sig[j]
            f[f"peak_ratio_{sfx}"] = float(tau[j] / denom)
            pre_tau, pre_sig = e.preshear_tau[m][j], e.preshear_sigma[m][j]
            if np.isfinite(pre_tau) and np.isfinite(pre_sig) and pre_sig > 0:
                f[f"preshear_ratio_{sfx}"] = float(pre_tau / pre_sig)
            curve = e.curves.get((rep, float(sig[j])))
            if curve is not None:
                shape = curve_shape(curve[0], curve[1], float(sig[j]), peak_window)
                f.update(_shape_features(shape, sfx))
                f[f"shear_end_ratio_{sfx}"] = shape.end_ratio_tau / float(sig[j])
        f.update(_locus(sig, tau))
        if np.all(np.isfinite(measured)):
            f.update(_locus(measured, tau, "_measured"))
        dens = e.bulk_density[m]
        if np.any(np.isfinite(dens)):
            f["bulk_density"] = float(np.nanmean(dens))
        conditioned = e.conditioned_bulk_density[m]
        ramp = e.compressibility.get(int(rep), (np.empty(0), np.empty(0)))
        f.update(_density_features(float(np.nanmean(conditioned)) if np.any(np.isfinite(conditioned)) else math.nan,
                                   ramp[0], rebase_compressibility(ramp[1])))
        out[int(rep)] = f
    return out


def step_mean(features: dict[str, float], stem: str) -> float:
    """The mean over the shear steps of a per-step feature (``stem``, e.g. ``"peak_ratio"``),
    its finite values only; NaN when there are none."""
    values = [v for k, v in features.items() if k.startswith(f"{stem}_") and k.endswith("kPa") and math.isfinite(v)]
    return float(np.mean(values)) if values else math.nan


@dataclass(frozen=True)
class FeatureSummary:
    """Several samples of one feature: their mean, sample standard deviation (NaN with one sample)
    and count, in the feature's unit."""

    mean: float
    sd: float
    n: int


def summarise(samples: Iterable[dict[str, float]]) -> dict[str, FeatureSummary]:
    """Mean, spread (sample s.d., ddof = 1) and count of every feature over samples (seeds or
    replicates); NaN samples are left out of a feature's count."""
    rows = list(samples)
    names = sorted({k for r in rows for k in r})
    out = {}
    for name in names:
        v = np.asarray([r[name] for r in rows if name in r and np.isfinite(r[name])], dtype=float)
        if v.size == 0:
            continue
        out[name] = FeatureSummary(float(np.mean(v)), float(np.std(v, ddof=1)) if v.size > 1 else math.nan, int(v.size))
    return out
