"""The yield locus: τ_peak = C + σ·tan(AIF), its least-squares fit and the FT4 report values.

All stresses in Pa, angles in degrees only at this edge (``aif_deg``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from calibrax.errors import ConfigError


@dataclass(frozen=True)
class MohrAnalysis:
    """What an FT4 user reads off the instrument's report (all Pa, degrees).

    ``major_principal_stress`` (MPS, σ1) comes from the Mohr circle through the preshear point and
    tangent to the locus; ``unconfined_yield_strength`` (UYS, fc) from the circle through the
    origin tangent to the locus; ``flow_function`` is FFC = MPS/UYS (``inf`` when UYS ≤ 0, i.e. a
    free-flowing, cohesionless locus); ``effective_angle_deg`` is δ, the angle of the line through
    the origin tangent to the MPS circle.
    """

    major_principal_stress: float
    unconfined_yield_strength: float
    flow_function: float
    effective_angle_deg: float


@dataclass(frozen=True)
class YieldLocus:
    """A straight yield locus fitted by least squares, with the regression standard errors.

    Attributes:
        normal_stress: σ of each point, shape (n,), Pa.
        shear_stress: τ_peak of each point, shape (n,), Pa.
        cohesion: C, the intercept, Pa.
        aif_deg: AIF, the angle of internal friction, degrees.
        cohesion_stderr: standard error of C, Pa.
        aif_stderr_deg: standard error of AIF (delta method through atan), degrees.
        r_squared: coefficient of determination of the fit.
    """

    normal_stress: np.ndarray
    shear_stress: np.ndarray
    cohesion: float
    aif_deg: float
    cohesion_stderr: float
    aif_stderr_deg: float
    r_squared: float

    @property
    def slope(self) -> float:
        """tan(AIF), dimensionless."""
        return math.tan(math.radians(self.aif_deg))

    @classmethod
    def fit(cls, normal_stress: np.ndarray, shear_stress: np.ndarray) -> "YieldLocus":
        """Fit τ = C + σ·tan(AIF) by ordinary least squares.

        Args:
            normal_stress: shape (n,), Pa, n ≥ 2 with at least two distinct values.
            shear_stress: shape (n,), Pa.

        The standard errors are the classical ones of linear regression (n − 2 degrees of
        freedom); with exactly two points they are NaN, as no residual is left to estimate them.
        """
        x = np.asarray(normal_stress, dtype=float).ravel()
        y = np.asarray(shear_stress, dtype=float).ravel()
        if x.shape != y.shape:
            raise ConfigError("yield_locus", f"σ and τ have different lengths ({x.size} and {y.size})")
        if x.size < 2 or np.ptp(x) == 0:
            raise ConfigError("yield_locus", "needs at least two points at distinct normal stresses")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise ConfigError("yield_locus", "σ and τ must be finite numbers")
        n = x.size
        xm, ym = x.mean(), y.mean()
        sxx = float(np.sum((x - xm) ** 2))
        slope = float(np.sum((x - xm) * (y - ym)) / sxx)
        intercept = float(ym - slope * xm)
        resid = y - (intercept + slope * x)
        ss_res = float(np.sum(resid**2))
        ss_tot = float(np.sum((y - ym) ** 2))
        r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
        if n > 2:
            s2 = ss_res / (n - 2)
            slope_se = math.sqrt(s2 / sxx)
            intercept_se = math.sqrt(s2 * (1.0 / n + xm**2 / sxx))
        else:
            slope_se = intercept_se = float("nan")
        aif = math.degrees(math.atan(slope))
        aif_se = math.degrees(slope_se / (1.0 + slope**2))
        return cls(x, y, intercept, aif, intercept_se, aif_se, r2)

    def shear_stress_at(self, normal_stress: float | np.ndarray) -> float | np.ndarray:
        """τ on the locus at σ (Pa)."""
        return self.cohesion + self.slope * np.asarray(normal_stress, dtype=float)

    def mohr(self, preshear_normal_stress: float, preshear_shear_stress: float | None = None) -> MohrAnalysis:
        """Mohr-circle analysis as the FT4 and ASTM D7891 report it.

        Args:
            preshear_normal_stress: σ_pre, Pa.
            preshear_shear_stress: τ_pre, Pa; defaults to the locus extrapolated to σ_pre.
        """
        phi = math.radians(self.aif_deg)
        t, c0 = math.tan(phi), self.cohesion
        sp = float(preshear_normal_stress)
        tp = float(self.shear_stress_at(sp)) if preshear_shear_stress is None else float(preshear_shear_stress)
        # Circle (centre s, radius r) tangent to τ = c0 + σ t: r = (c0 + s t) cos φ, through (sp, tp).
        # (sp − s)² + tp² = (c0 + s t)² cos² φ   → quadratic a s² + b s + k = 0, take the larger root.
        cos2 = math.cos(phi) ** 2
        a = 1.0 - t**2 * cos2
        b = -2.0 * sp - 2.0 * c0 * t * cos2
        k = sp**2 + tp**2 - c0**2 * cos2
        disc = b * b - 4.0 * a * k
        if -1e-9 * b * b < disc < 0:  # preshear point on the locus: tangent there (disc = 0 up to rounding)
            disc = 0.0
        if disc < 0 or a <= 0:
            nan = float("nan")
            return MohrAnalysis(nan, nan, nan, nan)
        centre = (-b + math.sqrt(disc)) / (2.0 * a)
        radius = (c0 + centre * t) * math.cos(phi)
        mps = centre + radius
        uys = 2.0 * c0 * math.cos(phi) / (1.0 - math.sin(phi))
        ffc = mps / uys if uys > 0 else float("inf")
        delta = math.degrees(math.asin(min(1.0, radius / centre))) if centre > 0 else float("nan")
        return MohrAnalysis(mps, uys, ffc, delta)
