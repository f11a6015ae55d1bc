"""The peak of a noisy plateau: the running mean's maximum reads high by about 2.5 of its own noise
s.d.s (quick's ratio of step to window), and ``procedure.peak_noise_correction`` reads it that much
lower (docs/explanation/sector.md).
Synthetic τ curves, made by hand: a rise to a plateau with noise of a known s.d."""

from __future__ import annotations

import numpy as np
import pytest

from calibrax.core.sheartest import Provenance, ShearCellSpec, ShearTestResult, StepRecord
from calibrax.core.sheartest.peaks import find_peak, running_mean_width, window_noise
from calibrax.errors import SpecError

ROTATION = np.linspace(0.0, 0.3, 301)  # quick's shear step: 0.3 rad, a sample per mrad
WINDOW = 0.03  # quick's peak window, rad
PLATEAU = 0.72  # τ/σ


def noisy_plateau(rng: np.random.Generator, noise: float, correlation: int = 5) -> np.ndarray:
    """τ/σ rising to PLATEAU by 0.05 rad, plus noise of s.d. ``noise`` correlated over
    ``correlation`` samples (a running mean of white noise, rescaled), shape (301,)."""
    rise = PLATEAU * np.minimum(1.0, ROTATION / 0.05)
    white = rng.normal(size=ROTATION.size + correlation - 1)
    coloured = np.convolve(white, np.ones(correlation), mode="valid")
    return rise + noise * coloured / np.std(coloured)


def test_window_noise_is_zero_on_a_smooth_curve_and_scales_with_the_noise() -> None:
    smooth = PLATEAU * np.minimum(1.0, ROTATION / 0.05)
    assert window_noise(ROTATION, smooth, WINDOW) == 0.0  # the rise is not noise
    peaked = smooth + 0.1 * np.exp(-(((ROTATION - 0.08) / 0.03) ** 2))  # a real peak, 0.06 rad wide
    assert window_noise(ROTATION, peaked, WINDOW) < 0.1 * 0.1  # counts a little as noise
    rng = np.random.default_rng(1)
    quiet = np.mean([window_noise(ROTATION, noisy_plateau(rng, 0.05), WINDOW) for _ in range(50)])
    loud = np.mean([window_noise(ROTATION, noisy_plateau(rng, 0.05 * np.sqrt(6)), WINDOW) for _ in range(50)])
    assert loud / quiet == pytest.approx(np.sqrt(6), rel=0.1)  # a 1/6 sector's torque is √6 as loud
    assert window_noise(ROTATION[:80], smooth[:80], WINDOW) == 0.0  # shorter than three windows
    assert running_mean_width(ROTATION, WINDOW) == 30


@pytest.mark.parametrize("noise", [0.02, 0.05, 0.1])
def test_the_maximum_reads_a_plateau_high_and_its_noise_correction_reads_it(noise) -> None:
    """Over 200 draws: the running mean's maximum lies about 2.5 noise s.d.s above the plateau, at
    every noise level; less 2.5 s.d.s of each draw's own measured noise, within 0.3 of one."""
    rng = np.random.default_rng(7)
    raw, corrected, sds = [], [], []
    for _ in range(200):
        curve = noisy_plateau(rng, noise)
        peak = find_peak(ROTATION, curve, WINDOW)[0]
        sd = window_noise(ROTATION, curve, WINDOW)
        raw.append(peak - PLATEAU)
        corrected.append(peak - 2.5 * sd - PLATEAU)
        sds.append(sd)
    sd = float(np.mean(sds))
    assert np.mean(raw) > 2.0 * sd
    assert abs(np.mean(corrected)) < 0.3 * sd


def one_shear_step_result(correction: float, curve: np.ndarray) -> ShearTestResult:
    spec = ShearCellSpec().replace(procedure={"shear_stresses": (9000.0,), "peak_window": WINDOW,
                                              "peak_noise_correction": correction})
    sigma = np.full(ROTATION.size, 9000.0)
    step = StepRecord("shear", 9000.0, ROTATION / 5.0, ROTATION, curve * sigma, sigma, np.full(ROTATION.size, 0.02))
    pre = StepRecord("preshear", 15000.0, ROTATION / 5.0, ROTATION, np.full(ROTATION.size, 9000.0),
                     np.full(ROTATION.size, 15000.0), np.full(ROTATION.size, 0.02))
    return ShearTestResult.from_steps(spec, [pre, step], [1500.0], Provenance("hand", "-", "-", 0, 1.0, 100))


def test_the_result_reads_its_peaks_less_the_correction_times_the_steps_noise() -> None:
    curve = noisy_plateau(np.random.default_rng(3), 0.05)
    plain = one_shear_step_result(0.0, curve)
    corrected = one_shear_step_result(2.5, curve)
    noise_pa = window_noise(ROTATION, curve * 9000.0, WINDOW)
    assert plain.peak_shear_stress[0] == pytest.approx(find_peak(ROTATION, curve * 9000.0, WINDOW)[0])
    assert corrected.peak_shear_stress[0] == pytest.approx(plain.peak_shear_stress[0] - 2.5 * noise_pa)
    assert corrected.peak_normal_stress[0] == plain.peak_normal_stress[0]


def test_the_default_reads_the_maximum_and_keeps_every_specs_hash() -> None:
    tiny = ShearCellSpec.preset("tiny")
    assert tiny.procedure.peak_noise_correction == 0.0
    assert tiny.spec_hash() == tiny.replace(procedure={"peak_noise_correction": 0.0}).spec_hash()
    assert tiny.spec_hash() != tiny.replace(procedure={"peak_noise_correction": 2.0}).spec_hash()


@pytest.mark.parametrize("value", [-1.0, 6.0])
def test_a_correction_out_of_range_is_refused_naming_the_field(value) -> None:
    with pytest.raises(SpecError, match="procedure.peak_noise_correction"):
        ShearCellSpec.preset("tiny").replace(procedure={"peak_noise_correction": value}).validate()
