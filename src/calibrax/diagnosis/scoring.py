"""Which candidate effect explains the gap: a joint fit per candidate, scored by its Bayes factor.

Inputs are numbers only (no simulator): a design of simulated feature vectors at known calibrated
parameters and effect magnitudes, and the experiment's replicate features. That keeps the
scoring testable on synthetic responses with known answers.

**Emulator.** Each feature is a linear model of the design inputs, fitted by least squares:
``f = b₀ + Σ b_i u_i + Σ_k (c_k g_k + d_k g_k²)`` with ``u`` the calibrated parameters scaled to
[−1, 1] over the design box (log-scaled where the campaign's parameter is) and ``g_k`` each effect
parameter as a fraction of its range; the g² term lets an effect saturate. Squares and products
of u join when they predict left-out simulations better (see :meth:`Emulator.fit`): over a box a
few plausible regions wide seed noise dwarfs any curvature in u, over a whole range it does not. The
residual s.d. ``s_j`` (seed scatter plus lack of fit, N − p degrees of freedom) and the residuals'
correlation ``R`` (shrunk half-way to the identity: features of one test move together, and four
peaks are not four independent witnesses) give the likelihood its covariance. Where the residual
s.d. exceeds the replicates' scatter (the pure error) beyond a lack-of-fit F test at 1 %, the two
are told apart: the pure error is the seed noise ``S`` and the excess, ``L``, the emulator's own
error (a rough wall's peak τ/σ at `tiny` takes off beyond any quadratic).

**Likelihood.** The experiment's replicate mean ``y`` against the emulator's mean ``μ(θ)``:
``y ~ N(μ(θ), Σ(θ))`` with ``Σ = D R D / n_exp + L R L + h(θ) s R s``, where ``D`` holds each
feature's replicate s.d. (never below the simulation's seed s.d. ``S``: a real test scatters at
least as much as the model's seeds), ``L`` the lack of fit (0 where the emulator fits; it does not
average out over the replicates as their noise does) and ``h(θ) = φᵀ(ΦᵀΦ)⁻¹φ`` the emulator's own
variance.

**Score: a Bayes factor, not BIC or a likelihood ratio.** Each model (no effect, or one candidate
switched on) is scored by its evidence ``Z = ∫ L(θ) p(θ) dθ``, the likelihood averaged over the
prior: flat over the design box for the calibrated parameters (the same for every model) and the
effect's own prior (flat over its range, or a measured wall friction angle). A candidate gains
only as much as its better fit outweighs the prior volume its extra parameter wastes (the Occam
factor), so an effect that fits no better than the noise loses to "no effect" by itself. BIC
would need a sample size, which a handful of correlated features does not have, and a likelihood
ratio test gives a p-value per candidate against "no effect", not a probability for each among
non-nested candidates. ``Z`` is integrated by quasi-Monte Carlo over the prior (2¹³ Sobol
points), and the models' probabilities are ``Z_k / Σ Z`` (equal prior odds).

**Verdict.** The top candidate when its Bayes factor against "no effect" is at least 3 ("positive"
evidence on Kass and Raftery's scale: a candidate that merely ties with the noise is not a finding)
and it leaves no feature implausible at its best fit; "no effect" when no candidate reaches that
factor and "no effect" itself leaves no feature implausible; otherwise "none of the candidates":
even the best model leaves a feature beyond ``|z| > 3`` (history matching's cut-off, Pukelsheim's
three-sigma rule for any unimodal distribution), or its best fit's joint misfit ``rᵀΣ⁻¹r`` fails a
χ² test at 1 % on (features − fitted parameters) degrees of freedom (nine features each within
three s.d. can still be jointly impossible).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import logsumexp
from scipy.stats import qmc

#: |z| beyond which a feature is implausible (history matching's cut-off)
IMPLAUSIBLE_Z = 3.0
#: weight of the identity in the shrunk residual correlation
CORRELATION_SHRINKAGE = 0.5
#: residual degrees of freedom the quadratic emulator must leave (PRESS guards against the rest)
MIN_QUADRATIC_DOF = 6
#: quasi-Monte Carlo points of the evidence integral (a power of two)
EVIDENCE_POINTS = 2 ** 13
NO_EFFECT = "none"
#: the best fit's χ² p-value below which its model cannot reproduce the features jointly
MIN_ADEQUACY = 0.01
#: a candidate wins only when its evidence beats "no effect" by this factor ("positive" evidence on
#: Kass and Raftery's scale); below it, the gap is put down to noise
MIN_BAYES_FACTOR = 3.0
#: a winning candidate whose best fit still leaves features beyond |z| = 3 is named all the same
#: when it removes at least this share of the no-effect model's χ² and leaves no feature beyond
#: |z| = 3 that was within it with no effect: it explains most of the gap, and what it leaves is
#: flagged (``Ranking.unexplained``) as the mark of an effect outside the list acting beside it;
#: otherwise the answer is "none of the candidates"
MIN_EXPLAINED = 0.5


@dataclass(frozen=True)
class CandidateSpace:
    """The parameters a model adds: names, their off values and ranges, and a prior quantile
    function per parameter (``ppf``: unit samples, shape (n,), to natural values)."""

    name: str
    label: str
    parameters: tuple[str, ...]
    off: tuple[float, ...]
    high: tuple[float, ...]
    priors: tuple[object, ...]
    prior_text: tuple[str, ...] = ()

    def scaled(self, values: np.ndarray) -> np.ndarray:
        """Natural values, shape (n, k), to fractions of the range above off, shape (n, k)."""
        off, high = np.asarray(self.off), np.asarray(self.high)
        return (np.asarray(values, dtype=float) - off) / (high - off)


@dataclass(frozen=True)
class Design:
    """Simulated features at known inputs.

    Attributes:
        unit: calibrated parameters scaled to [−1, 1] over the design box, shape (N, d).
        effects: every candidate's parameters as fractions of their range (0: off), shape (N, K),
            columns in the order of ``effect_columns``.
        effect_columns: the names of those columns.
        features: one row per simulation, shape (N, F), in the order of ``names``.
        names: feature names.
        at_target: per simulation, whether it ran at the target fidelity, shape (N,) of bool;
            None for a design at one fidelity (every simulation at the target). A design across
            two fidelities gives its emulator a shift per feature between them (see
            :meth:`Emulator.fit`).
        groups: per simulation, the design point it belongs to, shape (N,) of int: the seeds of
            one point share it, and their scatter is the pure error (:meth:`Emulator.fit`); None:
            every simulation a point of its own (no pure error).
    """

    unit: np.ndarray
    effects: np.ndarray
    effect_columns: tuple[str, ...]
    features: np.ndarray
    names: tuple[str, ...]
    at_target: np.ndarray | None = None
    groups: np.ndarray | None = None

    def only(self, keep: list[int]) -> "Design":
        """The same simulations with the features of the columns ``keep`` only."""
        return Design(self.unit, self.effects, self.effect_columns, self.features[:, keep],
                      tuple(self.names[j] for j in keep), self.at_target, self.groups)

    def rows(self, keep: np.ndarray) -> "Design":
        """The simulations where ``keep`` (shape (N,) of bool) holds."""
        return Design(self.unit[keep], self.effects[keep], self.effect_columns, self.features[keep], self.names,
                      self.at_target[keep] if self.at_target is not None else None,
                      self.groups[keep] if self.groups is not None else None)

    @property
    def two_levels(self) -> bool:
        """Whether the design holds simulations at both a cheap fidelity and the target."""
        return self.at_target is not None and bool(np.any(self.at_target)) and not bool(np.all(self.at_target))


@dataclass(frozen=True)
class Target:
    """The experiment's replicate statistics per feature (order of ``Design.names``): means,
    sample s.d. (NaN with one replicate) and the number of replicates."""

    mean: np.ndarray
    sd: np.ndarray
    n: int


@dataclass
class Emulator:
    """The features' linear models (see the module docstring) and their residual statistics."""

    coef: np.ndarray                 # (p, F)
    gram_inv: np.ndarray             # (p, p), (ΦᵀΦ)⁻¹
    sd: np.ndarray                   # (F,), residual s.d. of one simulation (seed noise and lack of fit)
    corr: np.ndarray                 # (F, F), shrunk residual correlation
    dof: int
    d: int
    effect_columns: tuple[str, ...]
    quadratic: bool = False
    #: whether the basis holds the target fidelity's shift (a design across two fidelities)
    shifted: bool = False
    #: per effect column, shape (K,): the target's signature is the cheap level's at this multiple
    #: of the effect's magnitude (1 where no target simulation had that effect on)
    level_scale: np.ndarray | None = None
    #: the pure error: the pooled s.d. of the seeds of one design point, shape (F,) (NaN: no
    #: point has two seeds), and its degrees of freedom
    pure_sd: np.ndarray | None = None
    pure_dof: int = 0
    #: per feature, shape (F,): the lack-of-fit F test's p-value, residual against pure error (NaN:
    #: not testable)
    lack_of_fit_p: np.ndarray | None = None
    #: directions in the calibrated parameters (rows, unit vectors, shape (m, d)) along which the
    #: target's own simulations spread: along them each feature at the target has a slope of its
    #: own beside the cheap level's (m = 0: the target is the cheap level plus its shift)
    target_directions: np.ndarray | None = None
    #: per effect column, shape (K,) of bool: whose signature at the target is read per feature from
    #: its point there, the cheap level's shape scaled by λ having failed to predict that point
    own_signature: np.ndarray | None = None

    @classmethod
    def fit(cls, design: Design) -> "Emulator":
        """Least squares on the linear basis, or on the one quadratic in the calibrated parameters
        too when that predicts the design's left-out simulations better (PRESS, the leave-one-out
        residuals e_i/(1 − h_ii), summed over the features in units of their spread) and leaves
        ``MIN_QUADRATIC_DOF`` residual degrees of freedom: a box the size of the whole
        parameter range bends (peak τ/σ saturates in μs), a few plausible regions wide it does not.

        A design across two fidelities (:attr:`Design.two_levels`) adds one regressor, the
        indicator of the target fidelity: each feature at the target is the cheap level's response
        plus a constant shift, the AR(1) model of Kennedy and O'Hagan (2000) with ρ = 1 and a
        constant bias. Where target simulations have an effect on (a candidate's point at the
        target, :func:`calibrax.diagnosis.design.level_point`), the effect's magnitude at the
        target is read on the cheap level's scale through a factor λ per effect column, fitted by
        least squares over every feature at once (``level_scale``): at `converged` a lateral wall
        friction of 0.3 moves peak τ/σ as one of 0.04 does at `tiny` (its shear zone is a thin
        band, not the whole bed), and a constant shift cannot carry that. The signatures' shape
        across the features and the response to the calibrated parameters come from the cheap
        level, except where the target's own simulations say otherwise: along the directions in
        which they spread (a refit confirmed there, :func:`spanned_directions`) each feature at
        the target gets a slope of its own, and an effect whose point at the target the scaled
        cheap signature fails to predict (:func:`_level_scales`) is read per feature from that
        point. :meth:`predict` answers at the target.

        The residual s.d. holds seed noise and the basis's lack of fit; the seeds of one design
        point (the replicates) give the pure error alone, and an F test of the one against the
        other (``lack_of_fit_p``) says where the emulator misfits (:attr:`noise_sd`)."""
        shifted = design.two_levels
        level = design.at_target.astype(float) if shifted else None
        n, k = design.features.shape[0], design.effects.shape[1]
        scalable = (np.flatnonzero(np.any((design.effects != 0) & design.at_target[:, None], axis=0))
                    if shifted else np.array([], dtype=int))
        directions = spanned_directions(design.unit[design.at_target]) if shifted else np.zeros((0, design.unit.shape[1]))
        own = np.zeros(k, dtype=bool)
        p_linear = basis(design.unit, design.effects, shift=level).shape[1] + directions.shape[0]
        if n <= p_linear + 1 + scalable.size:
            raise ValueError(f"the design has {n} simulations; its emulator needs more than {p_linear + 1 + scalable.size}")
        scale = np.ones(k)
        if scalable.size:
            scale, own = _level_scales(design, scalable)
        effects = _at_level(design.effects, design.at_target if shifted else None, scale)
        extra = _target_terms(design.unit, design.effects, level, directions, own) if shifted else None
        phi, quadratic = _chosen_basis(design.unit, effects, design.features, level, extra)
        gram_inv = np.linalg.pinv(phi.T @ phi)
        coef = gram_inv @ phi.T @ design.features
        resid = design.features - phi @ coef
        dof = n - np.linalg.matrix_rank(phi) - int(np.sum(~own[scalable]))
        sd = np.sqrt(np.sum(resid ** 2, axis=0) / max(dof, 1))
        sd = np.where(sd > 0, sd, np.max(np.abs(design.features), axis=0) * 1e-6 + 1e-12)
        raw = np.corrcoef(resid.T) if resid.shape[1] > 1 else np.ones((1, 1))
        raw = np.nan_to_num(np.atleast_2d(raw))
        corr = CORRELATION_SHRINKAGE * np.eye(raw.shape[0]) + (1 - CORRELATION_SHRINKAGE) * raw
        np.fill_diagonal(corr, 1.0)
        pure_sd, pure_dof = pure_error(design.features, design.groups)
        lof = _lack_of_fit(np.sum(resid ** 2, axis=0), int(dof), pure_sd, pure_dof)
        return cls(coef, gram_inv, sd, corr, int(dof), design.unit.shape[1], design.effect_columns, quadratic, shifted,
                   scale if scalable.size else None, pure_sd, pure_dof, lof, directions if shifted else None,
                   own if shifted else None)

    @property
    def misfit(self) -> np.ndarray:
        """Per feature, shape (F,) of bool: whether the emulator misfits the design beyond its
        seeds' scatter (lack-of-fit p-value below :data:`LACK_OF_FIT_P`)."""
        if self.lack_of_fit_p is None:
            return np.zeros(self.sd.shape, dtype=bool)
        return np.nan_to_num(self.lack_of_fit_p, nan=1.0) < LACK_OF_FIT_P

    @property
    def noise_sd(self) -> np.ndarray:
        """One simulation's seed s.d., per feature, shape (F,): the residual s.d. (many more
        degrees of freedom than the replicates give) unless the emulator misfits a feature, then
        the pure error there. Measured at `converged` with a rough wall: the residual s.d. of peak
        τ/σ at 6 kPa was 0.47, the replicates' scatter 0.075, and the misfit read as noise hid a
        gap of three standard errors. The target's own replicates alone are not used, though the
        target's seeds may scatter less than the cheap level's: two replicates give one degree of
        freedom, and in the double's two-fidelity test their s.d. came out 2.4 to 6 times below the
        design's, which called the noise a gap."""
        if self.pure_sd is None or self.pure_dof < 1:
            return self.sd
        return np.where(self.misfit & (self.pure_sd > 0), self.pure_sd, self.sd)

    @property
    def discrepancy_sd(self) -> np.ndarray:
        """The emulator's own error where it misfits, per feature, shape (F,): √(residual s.d.² −
        pure error²) where the lack of fit is significant, 0 elsewhere. Unlike seed noise it does
        not average out over an experiment's replicates."""
        if self.pure_sd is None:
            return np.zeros_like(self.sd)
        extra = np.sqrt(np.maximum(self.sd ** 2 - np.nan_to_num(self.pure_sd) ** 2, 0.0))
        return np.where(self.misfit, extra, 0.0)

    def predict(self, unit: np.ndarray, effects: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean features at the target fidelity, shape (n, F), and the emulator's relative
        variance h, shape (n,)."""
        unit = np.atleast_2d(unit)
        raw = np.atleast_2d(effects)
        effects = raw * self.level_scale[None, :] if self.level_scale is not None else raw
        at_target = np.ones(unit.shape[0]) if self.shifted else None
        extra = (_target_terms(unit, raw, at_target, self.target_directions, self.own_signature)
                 if self.shifted else None)
        phi = basis(unit, effects, self.quadratic, shift=at_target, extra=extra)
        h = np.einsum("ij,jk,ik->i", phi, self.gram_inv, phi)
        return phi @ self.coef, np.maximum(h, 0.0)


#: the lack-of-fit F test's p-value below which the emulator misfits a feature
LACK_OF_FIT_P = 0.01
#: singular value (u on [−1, 1]) beyond which the target's simulations spread along a direction
SPAN_TOLERANCE = 1e-6
#: the χ² test's p-value below which the cheap level's signature scaled by λ fails to predict an
#: effect's point at the target, whose signature is then read per feature there
LEVEL_SHAPE_P = 0.01
#: the range of the effect-by-level factor λ (:meth:`Emulator.fit`), and the grid it is searched on
LEVEL_SCALE_RANGE = (0.01, 10.0)
LEVEL_SCALE_GRID = 61


def pure_error(features: np.ndarray, groups: np.ndarray | None) -> tuple[np.ndarray, int]:
    """The pooled s.d. of the simulations within each group (design point), shape (F,), and its
    degrees of freedom Σ(nᵢ − 1); NaN and 0 where no group has two simulations."""
    f = features.shape[1]
    if groups is None:
        return np.full(f, np.nan), 0
    ss, dof = np.zeros(f), 0
    for g in np.unique(groups):
        rows = features[groups == g]
        if rows.shape[0] > 1:
            ss += np.sum((rows - rows.mean(axis=0)) ** 2, axis=0)
            dof += rows.shape[0] - 1
    return (np.sqrt(ss / dof) if dof else np.full(f, np.nan)), dof


def _lack_of_fit(ss_resid: np.ndarray, dof_resid: int, pure_sd: np.ndarray, pure_dof: int) -> np.ndarray:
    """Per feature, the p-value of the lack-of-fit F test: the residual's excess over the pure
    error per degree of freedom, against the pure error's (Draper and Smith, Applied Regression
    Analysis, 2.1); NaN where there is no pure error or no degree of freedom left for the misfit."""
    from scipy.stats import f as f_dist

    lof_dof = dof_resid - pure_dof
    if pure_dof < 1 or lof_dof < 1:
        return np.full(ss_resid.shape, np.nan)
    ss_pure = pure_sd ** 2 * pure_dof
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = (np.maximum(ss_resid - ss_pure, 0.0) / lof_dof) / (ss_pure / pure_dof)
    return np.where(np.isfinite(ratio), f_dist.sf(ratio, lof_dof, pure_dof), np.where(ss_pure > 0, 1.0, np.nan))


def _at_level(effects: np.ndarray, at_target: np.ndarray | None, scale: np.ndarray) -> np.ndarray:
    """Effect columns on the cheap level's scale: the target's rows times λ, shape (N, K)."""
    if at_target is None:
        return effects
    return np.where(at_target[:, None], effects * scale[None, :], effects)


def _chosen_basis(unit: np.ndarray, effects: np.ndarray, y: np.ndarray, level: np.ndarray | None,
                  extra: np.ndarray | None = None) -> tuple[np.ndarray, bool]:
    """The linear basis, or the quadratic one where PRESS prefers it (see :meth:`Emulator.fit`)."""
    linear = basis(unit, effects, shift=level, extra=extra)
    curved = basis(unit, effects, quadratic=True, shift=level, extra=extra)
    if y.shape[0] - curved.shape[1] >= MIN_QUADRATIC_DOF and _press(curved, y) < _press(linear, y):
        return curved, True
    return linear, False


def _level_scales(design: Design, columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The effect-by-level factors λ (see :meth:`Emulator.fit`), shape (K,), and which effect
    columns' signatures are read per feature at the target instead, shape (K,) of bool.

    The emulator fitted without the target's simulations that have an effect on predicts them, at
    the target, with each of ``columns`` times λ; λ minimises that prediction's squared error over
    the features in units of its s.d. (the seed noise, pure error where that emulator misfits, with
    its own variance and misfit), searched on a log grid from ``LEVEL_SCALE_RANGE[0]`` to where the
    target's largest magnitude reaches the cheap design's (λg = 1: no further, the cheap level's
    response is not known beyond it), then polished, twice round where there are several. Fitted
    with those simulations in, λ would instead make them points of high leverage that the effect's
    terms pass through (measured on the double: λ = 7 where the truth is 1).

    Where even the best λ leaves an effect's points beyond their noise (χ² on F·n − 1 degrees of
    freedom below ``LEVEL_SHAPE_P``), the cheap level's signature has another shape at the target,
    not only another size (at `converged` a rough wall raises the bulk density, at `tiny` it
    lowers it): that column's λ is 0 and its signature at the target is read per feature from its
    points there (:func:`_target_terms`), known as well as those few simulations know it."""
    from scipy.optimize import minimize_scalar
    from scipy.stats import chi2

    probe = design.at_target & np.any(design.effects[:, columns] != 0, axis=1)
    known = Emulator.fit(design.rows(~probe))
    noise2 = known.noise_sd ** 2
    misfit2 = known.discrepancy_sd ** 2
    unit, y, g = design.unit[probe], design.features[probe], design.effects[probe]

    def terms(scale: np.ndarray) -> np.ndarray:
        mu, h = known.predict(unit, g * scale[None, :])
        return (y - mu) ** 2 / (noise2[None, :] * (1.0 + h[:, None]) + misfit2[None, :])

    scale = np.ones(design.effects.shape[1])
    for _ in range(2 if columns.size > 1 else 1):
        for j in columns:
            reach = 1.0 / float(np.max(np.abs(g[:, j])))
            grid = np.log(np.geomspace(LEVEL_SCALE_RANGE[0], min(LEVEL_SCALE_RANGE[1], reach), LEVEL_SCALE_GRID))
            step = grid[1] - grid[0]

            def along(log_l: float, j: int = j) -> float:
                trial = scale.copy()
                trial[j] = math.exp(log_l)
                return float(np.sum(terms(trial)))
            best = grid[int(np.argmin([along(v) for v in grid]))]
            lo, hi = max(best - step, grid[0]), min(best + step, grid[-1])
            res = minimize_scalar(along, bounds=(lo, hi), method="bounded", options={"xatol": 1e-3})
            scale[j] = math.exp(res.x if res.fun <= along(best) else best)
    own = np.zeros(design.effects.shape[1], dtype=bool)
    z2 = terms(scale)
    for j in columns:
        rows = g[:, j] != 0
        dof = int(rows.sum()) * y.shape[1] - 1
        own[j] = dof >= 1 and float(chi2.sf(np.sum(z2[rows]), dof)) < LEVEL_SHAPE_P
    scale[own] = 0.0
    return scale, own


def _press(phi: np.ndarray, y: np.ndarray) -> float:
    """Leave-one-out squared residuals of a least-squares fit, summed over features scaled by
    their spread."""
    gram_inv = np.linalg.pinv(phi.T @ phi)
    hat = np.einsum("ij,jk,ik->i", phi, gram_inv, phi)
    resid = y - phi @ (gram_inv @ phi.T @ y)
    loo = resid / np.maximum(1.0 - hat, 1e-9)[:, None]
    scale = np.std(y, axis=0)
    return float(np.sum((loo / np.where(scale > 0, scale, 1.0)) ** 2))


def basis(unit: np.ndarray, effects: np.ndarray, quadratic: bool = False,
          shift: np.ndarray | None = None, extra: np.ndarray | None = None) -> np.ndarray:
    """The regressors [1, u, g, g²], shape (n, 1 + d + 2K), with ``quadratic`` the squares and
    products of u too, with ``shift`` (shape (n,): 1 at the target fidelity, 0 at the cheap one)
    the target's shift, and the target's own terms ``extra`` (shape (n, m), :func:`_target_terms`)
    last."""
    unit = np.atleast_2d(unit)
    effects = np.atleast_2d(effects)
    cols = [np.ones((unit.shape[0], 1)), unit, effects, effects ** 2]
    if quadratic:
        d = unit.shape[1]
        cols.append(np.column_stack([unit[:, i] * unit[:, j] for i in range(d) for j in range(i, d)]))
    if shift is not None:
        cols.append(np.asarray(shift, dtype=float).reshape(-1, 1))
    if extra is not None and extra.shape[1]:
        cols.append(extra)
    return np.hstack(cols)


def spanned_directions(target_unit: np.ndarray) -> np.ndarray:
    """The directions in the calibrated parameters along which the target's simulations spread
    about their mean, rows of unit length, shape (m, d), m ≤ min(n − 1, d): where the target has
    simulations at more than one calibrated point (a refit confirmed there), each feature there gets
    a slope of its own along them, the AR(1) model's bias δ(x) linear where the data can tell
    (Kennedy and O'Hagan 2000); the slope of the rest is the cheap level's."""
    u = np.atleast_2d(np.asarray(target_unit, dtype=float))
    if u.shape[0] < 2:
        return np.zeros((0, u.shape[1]))
    _, sv, vt = np.linalg.svd(u - u.mean(axis=0), full_matrices=False)
    return vt[sv > SPAN_TOLERANCE]


def _target_terms(unit: np.ndarray, effects: np.ndarray, at_target: np.ndarray | None, directions: np.ndarray | None,
                  own: np.ndarray | None) -> np.ndarray:
    """The target's own regressors, zero at the cheap level, shape (n, m + k): u along each of
    ``directions`` (shape (m, d)), and each effect column of ``own`` (shape (K,) of bool, k of them
    true) as its fraction of the range, raw (its signature at the target read per feature)."""
    unit = np.atleast_2d(unit)
    n = unit.shape[0]
    level = np.ones(n) if at_target is None else np.asarray(at_target, dtype=float)
    along = unit @ directions.T if directions is not None and directions.size else np.zeros((n, 0))
    mine = np.atleast_2d(effects)[:, own] if own is not None and own.any() else np.zeros((n, 0))
    return np.hstack([along, mine]) * level[:, None]


@dataclass(frozen=True)
class ModelScore:
    """One model's fit: its log evidence and probability, its best point (natural effect values and
    the calibrated parameters on [−1, 1]) with the posterior's mean and 95 % interval of each effect
    parameter (and the calibrated parameters' posterior mean), and the standardised residuals z of
    every feature at its best point."""

    name: str
    label: str
    log_evidence: float
    probability: float
    best_unit: np.ndarray
    best_effect: dict[str, float]
    effect_mean: dict[str, float]
    effect_interval: dict[str, tuple[float, float]]
    z: np.ndarray
    prior_text: tuple[str, ...] = ()
    #: the posterior mean of the calibrated parameters on [−1, 1], shape (d,)
    mean_unit: np.ndarray | None = None
    #: the best fit's joint misfit rᵀΣ⁻¹r and its degrees of freedom (features − fitted parameters)
    chi2: float = math.nan
    dof: int = 0

    @property
    def adequacy(self) -> float:
        """The χ² test's p-value of the best fit: the chance of a misfit at least this large if
        the model were right (small: the model cannot reproduce the features jointly)."""
        from scipy.stats import chi2

        return float(chi2.sf(self.chi2, max(self.dof, 1))) if math.isfinite(self.chi2) else math.nan

    @property
    def max_abs_z(self) -> float:
        return float(np.nanmax(np.abs(self.z))) if self.z.size else 0.0


@dataclass(frozen=True)
class Ranking:
    """Every model scored (most probable first) and the verdict: the name of the winning candidate,
    ``"none"`` (the gap is within the noise) or ``"none of the candidates"``. ``unexplained``: where
    the verdict names a candidate that explains most of the gap but not all of it, what it leaves
    (features beyond |z| = 3 at its best fit, or the joint χ²): the gap an effect outside the list
    leaves; empty otherwise."""

    models: list[ModelScore]
    verdict: str
    reason: str
    names: tuple[str, ...] = field(default_factory=tuple)
    unexplained: tuple[str, ...] = ()

    @property
    def gap_left(self) -> bool:
        """Whether a named candidate leaves part of the gap unexplained."""
        return bool(self.unexplained)

    def model(self, name: str) -> ModelScore:
        return next(m for m in self.models if m.name == name)


NONE_OF_THEM = "none of the candidates"


def _covariances(target: Target, emulator: Emulator, h: np.ndarray) -> np.ndarray:
    """Σ(θ) for each of n points, shape (n, F, F)."""
    noise = emulator.noise_sd
    d_exp = np.where(np.isfinite(target.sd), np.maximum(target.sd, noise), noise)
    base = (d_exp[:, None] * emulator.corr * d_exp[None, :]) / target.n
    sim = emulator.sd[:, None] * emulator.corr * emulator.sd[None, :]
    miss = emulator.discrepancy_sd
    discrepancy = miss[:, None] * emulator.corr * miss[None, :]
    return (base + discrepancy)[None] + h[:, None, None] * sim[None]


def log_likelihood(target: Target, emulator: Emulator, unit: np.ndarray,
                   effects: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian log likelihood of the experiment at n points, shape (n,), and each feature's
    standardised residual z = (y − μ)/√Σ_jj, shape (n, F)."""
    mu, h = emulator.predict(unit, effects)
    cov = _covariances(target, emulator, h)
    r = target.mean[None, :] - mu
    chol = np.linalg.cholesky(cov)
    w = np.linalg.solve(chol, r[..., None])[..., 0]
    logdet = 2.0 * np.sum(np.log(np.diagonal(chol, axis1=1, axis2=2)), axis=1)
    f = r.shape[1]
    ll = -0.5 * (np.sum(w ** 2, axis=1) + logdet + f * math.log(2 * math.pi))
    z = r / np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    return ll, z


def _prior_samples(d: int, candidate: CandidateSpace | None, seed: int) -> tuple[np.ndarray, np.ndarray]:
    k = len(candidate.parameters) if candidate else 0
    u = qmc.Sobol(d + k, scramble=True, seed=seed).random(EVIDENCE_POINTS)
    unit = 2.0 * u[:, :d] - 1.0
    if not k:
        return unit, np.zeros((u.shape[0], 0))
    natural = np.column_stack([prior.ppf(u[:, d + i]) for i, prior in enumerate(candidate.priors)])
    return unit, natural


def score_model(target: Target, emulator: Emulator, candidate: CandidateSpace | None, seed: int = 0) -> ModelScore:
    """The evidence and best fit of one model (``candidate`` None: no effect)."""
    unit, natural = _prior_samples(emulator.d, candidate, seed)
    effects = np.zeros((unit.shape[0], len(emulator.effect_columns)))
    if candidate is not None:
        cols = [emulator.effect_columns.index(p) for p in candidate.parameters]
        effects[:, cols] = candidate.scaled(natural)
    ll, z = log_likelihood(target, emulator, unit, effects)
    log_z = float(logsumexp(ll) - math.log(ll.size))
    best = int(np.argmax(ll))
    best_unit, best_eff = _refine(target, emulator, unit[best], effects[best], candidate)
    ll_best, z_best = log_likelihood(target, emulator, best_unit[None], best_eff[None])
    chi2 = _mahalanobis(target, emulator, best_unit, best_eff)
    w = np.exp(ll - ll.max())
    w /= w.sum()
    mean, interval, best_natural = {}, {}, {}
    if candidate is not None:
        for i, name in enumerate(candidate.parameters):
            col = emulator.effect_columns.index(name)
            v = natural[:, i]
            mean[name] = float(np.sum(w * v))
            interval[name] = (_weighted_quantile(v, w, 0.025), _weighted_quantile(v, w, 0.975))
            best_natural[name] = float(candidate.off[i] + best_eff[col] * (candidate.high[i] - candidate.off[i]))
    name = candidate.name if candidate else NO_EFFECT
    label = candidate.label if candidate else "no effect"
    k = len(candidate.parameters) if candidate else 0
    return ModelScore(name, label, log_z, math.nan, best_unit, best_natural, mean, interval, z_best[0],
                      candidate.prior_text if candidate else (), np.sum(w[:, None] * unit, axis=0), chi2,
                      target.mean.size - emulator.d - k)


def _mahalanobis(target: Target, emulator: Emulator, unit: np.ndarray, effects: np.ndarray) -> float:
    """rᵀΣ⁻¹r of the experiment against the emulator at one point."""
    mu, h = emulator.predict(unit[None], effects[None])
    cov = _covariances(target, emulator, h)[0]
    r = target.mean - mu[0]
    return float(r @ np.linalg.solve(cov, r))


def _refine(target: Target, emulator: Emulator, unit: np.ndarray, effects: np.ndarray,
            candidate: CandidateSpace | None) -> tuple[np.ndarray, np.ndarray]:
    """Polish the best prior sample into the likelihood's maximum within the box and the range."""
    from scipy.optimize import minimize

    cols = [emulator.effect_columns.index(p) for p in candidate.parameters] if candidate else []
    x0 = np.concatenate([unit, effects[cols]])
    bounds = [(-1.0, 1.0)] * unit.size + [(0.0, 1.0)] * len(cols)

    def negative(x: np.ndarray) -> float:
        eff = effects.copy()
        eff[cols] = x[unit.size:]
        return -float(log_likelihood(target, emulator, x[None, :unit.size], eff[None])[0][0])

    negative_x0 = negative(x0)
    res = minimize(negative, x0, bounds=bounds, method="L-BFGS-B")
    x = res.x if res.success and res.fun <= negative_x0 else x0
    eff = effects.copy()
    eff[cols] = x[unit.size:]
    return x[:unit.size], eff


def _weighted_quantile(v: np.ndarray, w: np.ndarray, q: float) -> float:
    order = np.argsort(v)
    cdf = np.cumsum(w[order])
    return float(v[order][min(np.searchsorted(cdf, q), v.size - 1)])


def rank(target: Target, design: Design, candidates: list[CandidateSpace], seed: int = 0,
         emulator: Emulator | None = None) -> Ranking:
    """Score "no effect" and every candidate on the same emulator (``Emulator.fit(design)`` unless
    the caller has fitted it already) and give the verdict."""
    emulator = emulator or Emulator.fit(design)
    models = [score_model(target, emulator, None, seed)] + [score_model(target, emulator, c, seed) for c in candidates]
    log_z = np.array([m.log_evidence for m in models])
    prob = np.exp(log_z - logsumexp(log_z))
    models = [ModelScore(**{**m.__dict__, "probability": float(p)}) for m, p in zip(models, prob)]
    models.sort(key=lambda m: -m.probability)
    none = next(m for m in models if m.name == NO_EFFECT)
    best = next((m for m in models if m.name != NO_EFFECT), None)
    factor = math.exp(min(best.log_evidence - none.log_evidence, 700.0)) if best else 0.0
    top = best if best is not None and factor >= MIN_BAYES_FACTOR else none
    worst = [design.names[j] for j in np.flatnonzero(np.abs(top.z) > IMPLAUSIBLE_Z)]
    if not worst and top.adequacy < MIN_ADEQUACY:
        worst = [f"the features jointly (χ² {top.chi2:.1f} on {top.dof} degrees of freedom, p = {top.adequacy:.2g})"]
    explained = 1.0 - top.chi2 / none.chi2 if none.chi2 > 0 and math.isfinite(top.chi2) else 0.0
    unexplained: tuple[str, ...] = ()
    # a candidate "explains most of the gap" only where it does not trade it for a new misfit: every
    # feature it leaves beyond |z| was beyond it with no effect too (a fit that spreads a gap no
    # candidate makes over the other features removes χ² without explaining anything)
    new_misfits = [design.names[j] for j in np.flatnonzero(np.abs(top.z) > IMPLAUSIBLE_Z)
                   if abs(none.z[j]) <= IMPLAUSIBLE_Z]
    if worst and top.name != NO_EFFECT and explained >= MIN_EXPLAINED and not new_misfits:
        verdict, unexplained = top.name, tuple(worst)
        reason = (f"{top.label} explains most of the gap (p = {top.probability:.2f}, Bayes factor {factor:.3g} against "
                  f"no effect; it removes {explained:.0%} of no effect's χ²) but leaves {', '.join(worst)} beyond "
                  f"|z| = {IMPLAUSIBLE_Z:g} at its best fit: an effect outside the candidates acts beside it")
    elif worst:
        verdict = NONE_OF_THEM
        why = ""
        if top.name != NO_EFFECT and new_misfits:
            why = (f" (it removes {explained:.0%} of no effect's χ², but by putting {', '.join(new_misfits)} beyond "
                   f"|z| = {IMPLAUSIBLE_Z:g}, which no effect fitted)")
        elif top.name != NO_EFFECT:
            why = f" (it removes only {explained:.0%} of no effect's χ², < {MIN_EXPLAINED:.0%})"
        reason = (f"the best model ({top.label}, p = {top.probability:.2f}) still leaves "
                  f"{', '.join(worst)} beyond |z| = {IMPLAUSIBLE_Z:g} at its best fit" + why)
    elif top.name == NO_EFFECT:
        verdict = NO_EFFECT
        reason = (f"no effect: the gap is within the noise (no candidate's Bayes factor against no effect reaches "
                  f"{MIN_BAYES_FACTOR:g}; the best, {best.label if best else '–'}, has {factor:.2g})")
    else:
        verdict = top.name
        reason = (f"{top.label} explains the gap (p = {top.probability:.2f}, Bayes factor {factor:.3g} against no "
                  f"effect; every feature within |z| ≤ {IMPLAUSIBLE_Z:g} at its best fit)")
    return Ranking(models, verdict, reason, design.names, unexplained)
