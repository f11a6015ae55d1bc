"""Look inside one numba_dem shear test: is the bed under the head filled between the blades, where
does the shear zone lie, is each preshear steady, how well is σ held. The instrument that found the
largest part of the seed scatter (issue 32): with the blades placed above the bed and the head
brought down at the preshear stress, the space between the blades stayed empty (solid fraction
below 0.03 within 1.5 diameters of the disc) and τ measured blade edges sliding on the bed's top.

    .venv/bin/python benchmarks/shear_diagnostics.py --preset tiny --seed 1
    .venv/bin/python benchmarks/shear_diagnostics.py --preset quick --seed 3 --set sliding_friction=0.3

It prints, after consolidation and after the first preshear, the solid fraction in slices of half
a particle diameter below the head's disc (the blades' zone first); for every step the mean
angular velocity of the particles over the head's rate in ten layers from the base to the head
(averaged over the step), the height where it crosses one half (the shear zone's middle) and the
height between 10 % and 90 % (its width), in particle diameters above the base; then each
preshear's rotation and drift and each step's σ error, from the result.

With ``--every RAD`` it also prints, for every step, one line per RAD of rotation: τ/σ over that
stretch, the spin profile and the zone's middle and width. That is how the remaining scatter was
traced to the shearing itself (issue 32): within one step τ/σ swings between about 0.5 and 0.95
from one 0.03 rad stretch to the next while the zone, the whole bed between the rib tops and the
blade tips, wanders by 2–3 diameters; in one step τ/σ read 0.13–0.34 and later 0.88 with the same
velocity profile.

    .venv/bin/python benchmarks/shear_diagnostics.py --preset tiny --seed 3 --every 0.03
"""

from __future__ import annotations

import argparse
import logging
import math
import sys

import numpy as np

LAYERS = 10


def solid_fraction_below_head(driver, slices: int = 8) -> list[float]:
    """Solid fraction (1) of slices of half a diameter below the head's disc, top first: each
    sphere's cross-section summed at heights sampled through the slice, over the vessel's area."""
    from calibrax_numba_dem.layout import H_Z

    x, r = driver.sys.x, driver.sys.rad
    zh, rc, d = driver.sys.head[H_Z], driver.rc, 2.0 * driver.spec.radius
    out = []
    for k in range(slices):
        zs = np.linspace(zh - (k + 1) * 0.5 * d, zh - k * 0.5 * d, 12)
        area = [np.sum(np.pi * np.clip(r**2 - (x[:, 2] - z) ** 2, 0.0, None)) for z in zs]
        out.append(float(np.mean(area) / (math.pi * rc**2)))
    return out


def spin_profile(driver) -> np.ndarray:
    """Mean angular velocity about the axis (rad/s) of the particles in LAYERS equal layers from the
    base to the head's disc, shape (LAYERS,); NaN for an empty layer."""
    from calibrax_numba_dem.layout import H_Z

    x, v = driver.sys.x, driver.sys.v
    rho2 = x[:, 0] ** 2 + x[:, 1] ** 2
    keep = rho2 > 1e-12
    omega = (x[keep, 0] * v[keep, 1] - x[keep, 1] * v[keep, 0]) / rho2[keep]
    layer = np.clip((x[keep, 2] / driver.sys.head[H_Z] * LAYERS).astype(int), 0, LAYERS - 1)
    sums = np.bincount(layer, omega, LAYERS)
    counts = np.bincount(layer, minlength=LAYERS)
    return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def zone(profile: np.ndarray, head_height: float, diameter: float) -> tuple[float, float]:
    """(middle, width) of the shear zone in particle diameters above the base: where the spin
    profile (over the head's rate, shape (LAYERS,)) crosses 0.5, and the height from its 0.1 to
    its 0.9 crossing (NaN where it does not cross)."""
    z = (np.arange(LAYERS) + 0.5) / LAYERS * head_height / diameter

    def crossing(level: float) -> float:
        for k in range(LAYERS - 1):
            a, b = profile[k], profile[k + 1]
            if np.isfinite(a) and np.isfinite(b) and (a - level) * (b - level) <= 0 and a != b:
                return float(z[k] + (level - a) / (b - a) * (z[k + 1] - z[k]))
        return math.nan

    return crossing(0.5), crossing(0.9) - crossing(0.1)


def print_stretches(step, profiles: np.ndarray, angles: np.ndarray, every: float, head_height: float,
                    diameter: float) -> None:
    """One line per ``every`` rad of a step's rotation: τ/σ over that stretch (from the step's
    samples), the mean spin profile over it (``profiles`` over the head's rate, shape (k, LAYERS), at
    head rotations ``angles`` since the step's start, shape (k,)) and the zone it gives."""
    print(f"  {step.kind} at {step.target_stress / 1e3:.0f} kPa, per {every} rad: τ/σ | spin, base to head | zone")
    for start in np.arange(0.0, float(step.rotation[-1]), every):
        rec = (step.rotation > start) & (step.rotation <= start + every)
        inside = (angles > start) & (angles <= start + every)
        if not rec.any() or not inside.any():
            continue
        prof = np.nanmean(profiles[inside], axis=0)
        middle, width = zone(prof, head_height, diameter)
        ratio = np.mean(step.shear_stress[rec]) / np.mean(step.normal_stress[rec])
        print(f"    {start:5.2f} rad  {ratio:4.2f} | " + " ".join(f"{v:5.2f}" for v in prof)
              + f" | middle {middle:4.1f} d, width {width:4.1f} d")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--preset", default="tiny")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help="a material field")
    p.add_argument("--every", type=float, metavar="RAD",
                   help="also print τ/σ and the spin profile for every RAD of each step's rotation")
    args = p.parse_args(argv)
    if args.every is not None and not args.every > 0:
        p.error(f"--every must be a rotation > 0 rad, got {args.every}")
    from calibrax import ShearCellSpec
    from calibrax.core.sheartest import Provenance, ShearTestResult
    from calibrax_numba_dem.layout import H_PHI, H_Z
    from calibrax.core.sheartest.stage_records import summarise
    from calibrax_numba_dem.procedure import RunLog, ShearTestDriver

    material = {k: float(v) for k, _, v in (s.partition("=") for s in args.set)}
    spec = ShearCellSpec.preset(args.preset, material=material, numerics={"seed": args.seed, "threads": 1}).validate()
    d = 2.0 * spec.radius
    driver = ShearTestDriver(spec, RunLog(logging.getLogger("shear_diagnostics")))
    rate = spec.procedure.rotation_rate
    profiles: list[tuple[str, float, np.ndarray, float]] = []
    plain_rotate = driver.rotate

    def rotate(stage):
        samples: list[np.ndarray] = []
        angles: list[float] = []
        plain_advance = driver.sys.advance
        phi0 = float(driver.sys.head[H_PHI])

        def advance(n: int) -> None:
            plain_advance(n)
            samples.append(spin_profile(driver))
            angles.append(float(driver.sys.head[H_PHI]) - phi0)
        driver.sys.advance = advance
        try:
            record = plain_rotate(stage)
        finally:
            del driver.sys.advance
        step = record.step
        profiles.append((stage.kind, stage.stress, np.nanmean(np.asarray(samples), axis=0) / rate, float(driver.sys.head[H_Z])))
        if args.every:
            print_stretches(step, np.asarray(samples) / rate, np.asarray(angles), args.every, float(driver.sys.head[H_Z]), d)
        if len(profiles) == 1:
            print("solid fraction below the head after the first preshear (top first, half-diameter slices): "
                  + " ".join(f"{v:.2f}" for v in solid_fraction_below_head(driver)))
        return record

    driver.rotate = rotate
    plain_consolidate, plain_insert = driver.consolidate, driver.insert_blades
    inserted = []

    def insert_blades(stage):
        inserted.append(plain_insert(stage))
        return inserted[-1]

    def consolidate(stage):
        record = plain_consolidate(stage)
        print(f"{spec.name}, seed {args.seed}: blade zone {spec.geometry.blade_height / d:.1f} diameters; head face "
              f"{inserted[-1].gap_radii:+.2f} radii from the poured bed's top after insertion")
        print("solid fraction below the head after consolidation (top first, half-diameter slices): "
              + " ".join(f"{v:.2f}" for v in solid_fraction_below_head(driver)))
        return record
    driver.consolidate, driver.insert_blades = consolidate, insert_blades
    summary = summarise(driver.run())
    print(f"\nspin over the head's rate, {LAYERS} layers from the base (left) to the head (right); shear zone in "
          "particle diameters above the base (blade tips at the head's height minus the blade height):")
    for kind, stress, prof, zh in profiles:
        middle, width = zone(prof, zh, d)
        print(f"  {kind:8s} {stress / 1e3:4.0f} kPa: " + " ".join(f"{v:5.2f}" for v in prof)
              + f" | middle {middle:4.1f} d, width {width:4.1f} d, blade tips at {(zh - spec.geometry.blade_height) / d:4.1f} d")
    result = ShearTestResult.from_steps(spec, summary.steps, summary.bulk_density,
                                        Provenance("numba_dem", "-", spec.spec_hash(), args.seed, 0.0, driver.sys.n),
                                        driver.warnings)
    print("\npreshear rotation [rad]: " + " ".join(f"{v:.2f}" for v in result.preshear_rotation)
          + "; drift: " + " ".join(f"{v:.1%}" for v in result.preshear_drift))
    print("σ error per step: " + " ".join(f"{v:+.1%}" for v in driver.sigma_errors))
    print("preshear τ/σ: " + " ".join(f"{v:.3f}" for v in result.preshear_shear_stress / result.preshear_normal_stress))
    print("peak τ/σ: " + " ".join(f"{v:.3f}" for v in result.peak_shear_stress / result.peak_normal_stress))
    for w in result.warnings:
        print("warning:", w)
    return 0


if __name__ == "__main__":
    sys.exit(main())
