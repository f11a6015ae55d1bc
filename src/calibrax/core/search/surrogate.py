"""The Kriging surrogate: a GPyTorch Gaussian process through BoTorch.

``SingleTaskGP`` with a Matérn-5/2 kernel and one length scale per parameter (ARD), on inputs
already in the unit cube (log-scaled where the parameter is), outcomes standardised. BoTorch
*maximises*, so the model is fitted to the negated (transformed) distance; :meth:`Kriging.predict`
gives the distance back.

DEM is noisy, and a distance is noisier: at the true parameters one seed's c_aif distance on the
``tiny`` cell scatters from 0.7 to 2.3. Left to itself, the marginal likelihood of a dozen points
explains that scatter as signal (fitted noise 0.007 in standardised units), the model interpolates
lucky seeds and the search chases them. Two defaults keep the model honest:

* ``transform="log1p"``: the GP models log(1 + d). Distances far from the optimum (up to 33 on the
  quickstart box) otherwise dominate the standardised outcome, and the valley, where the search must
  resolve differences of one noise unit, is flattened into the bottom of the scale;
* ``noise_sd``: the expected 1-σ scatter of one evaluation's d near the optimum, from the metric's
  own noise law (see :func:`noise_sd_from_threshold`). It sets a log-normal prior on the GP's noise
  (centred there, one e-fold wide) and a floor a twentieth of it: the noise is still fitted, but it
  cannot collapse below what the metric says one seed does.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import torch

DTYPE = torch.float64
TRANSFORMS = ("log1p", "identity")
#: the multi-fidelity model's kernel: ``ar1`` (Kennedy and O'Hagan's autoregressive co-Kriging,
#: :mod:`calibrax.core.search.fidelity_kernel`) or ``linear_truncated`` (BoTorch's
#: ``SingleTaskMultiFidelityGP``); chosen by benchmarks/multifidelity.py
FIDELITY_KERNEL = "ar1"
#: evaluations per chunk in :meth:`Kriging.latent` (memory: chunk × training points)
PREDICT_CHUNK = 4096


def noise_sd_from_threshold(threshold: float) -> float:
    """1-σ scatter of one evaluation's distance at the true parameters, from the metric's 95 % noise
    threshold T: d at the truth follows roughly a χ law (2–3 features), whose s.d. is about a
    quarter of its 95 % quantile (χ₂: 0.66 of 2.45; χ₃: 0.69 of 2.80). NaN in, NaN out."""
    return threshold / 4.0 if math.isfinite(threshold) and threshold > 0 else math.nan


def _forward(distance: np.ndarray, transform: str) -> np.ndarray:
    return np.log1p(np.maximum(distance, 0.0)) if transform == "log1p" else distance


def _inverse(value: np.ndarray, transform: str) -> np.ndarray:
    return np.expm1(value) if transform == "log1p" else value


@dataclass
class Kriging:
    """A fitted GP model of −(transformed distance) over the unit cube. ``model`` is the BoTorch
    model; ``transform`` says how the distance was transformed (``log1p`` or ``identity``)."""

    model: object
    train_x: torch.Tensor
    train_y: torch.Tensor  # shape (n, 1): −transform(distance)
    transform: str = "identity"
    noise_floor: float = 0.0  # standardised units; 0: none
    #: Cholesky factor and α of the training system, filled by :meth:`_solved` on first use
    _cache: tuple | None = field(default=None, repr=False, compare=False)

    @classmethod
    def fit(cls, x: np.ndarray, distance: np.ndarray, seed: int = 0, *, transform: str = "identity",
            noise_sd: float | None = None, fidelity_column: int | None = None) -> "Kriging":
        """Fit on ``x`` shape (n, d) in [0, 1]^d and ``distance`` shape (n,). Needs n ≥ 2.

        Args:
            transform: ``log1p`` (model log(1 + d)) or ``identity``.
            noise_sd: expected 1-σ scatter of one evaluation's distance near the optimum (distance
                units); None or NaN: the noise is fitted freely (BoTorch's default prior).
            fidelity_column: the column of ``x`` that holds a fidelity level in [0, 1] (1: the
                target); the model is then BoTorch's ``SingleTaskMultiFidelityGP`` (a Matérn-5/2
                kernel over the parameters times a linear truncated fidelity kernel, which lets
                the cheaper levels carry a bias that vanishes at the target).
        """
        from botorch.fit import fit_gpytorch_mll
        from botorch.models import SingleTaskGP, SingleTaskMultiFidelityGP
        from botorch.models.transforms.outcome import Standardize
        from gpytorch.constraints import GreaterThan
        from gpytorch.kernels import MaternKernel, ScaleKernel
        from gpytorch.likelihoods import GaussianLikelihood
        from gpytorch.mlls import ExactMarginalLogLikelihood
        from gpytorch.priors import GammaPrior, LogNormalPrior

        if transform not in TRANSFORMS:
            raise ValueError(f"transform must be one of {TRANSFORMS}, got {transform!r}")
        torch.manual_seed(seed)
        dist = np.asarray(distance, dtype=float)
        y = _forward(dist, transform)
        tx = torch.as_tensor(np.asarray(x, dtype=float), dtype=DTYPE)
        ty = -torch.as_tensor(y, dtype=DTYPE).reshape(-1, 1)
        d = tx.shape[-1]
        # The classic Kriging priors of BoTorch's legacy default: keep length scales O(0.1–1) of the
        # cube when only a handful of points is known.
        covar = ScaleKernel(MaternKernel(nu=2.5, ard_num_dims=d, lengthscale_prior=GammaPrior(3.0, 6.0)),
                            outputscale_prior=GammaPrior(2.0, 0.15))
        likelihood, floor = None, 0.0
        if noise_sd is not None and math.isfinite(noise_sd) and noise_sd > 0:
            # the noise near the optimum in the model's units: through the transform's slope there
            # (log1p: 1/(1 + d), at the smallest distance seen), then standardised as Standardize does
            slope = 1.0 / (1.0 + max(float(np.min(dist)), 0.0)) if transform == "log1p" else 1.0
            y_sd = float(np.std(y, ddof=1)) if y.size > 1 else 1.0
            var = (noise_sd * slope / (y_sd if y_sd > 0 else 1.0)) ** 2
            floor = var / 20.0
            likelihood = GaussianLikelihood(noise_prior=LogNormalPrior(math.log(var), 1.0),
                                            noise_constraint=GreaterThan(floor))
            likelihood.noise = var
        extra = {"likelihood": likelihood} if likelihood is not None else {}
        if fidelity_column is not None and FIDELITY_KERNEL == "linear_truncated":
            model = SingleTaskMultiFidelityGP(tx, ty, data_fidelities=[fidelity_column],
                                              outcome_transform=Standardize(m=1), **extra)
        else:
            if fidelity_column is not None:
                from calibrax.core.search.fidelity_kernel import AutoregressiveFidelityKernel

                covar = AutoregressiveFidelityKernel(d - 1)
            model = SingleTaskGP(tx, ty, covar_module=covar, outcome_transform=Standardize(m=1), **extra)
        mll = ExactMarginalLogLikelihood(model.likelihood, model)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                fit_gpytorch_mll(mll)
            except Exception:  # noqa: BLE001 — a failed hyperparameter fit keeps the priors' mode
                pass
        model.eval()
        return cls(model, tx, ty, transform, floor)

    def _solved(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Cholesky factor of K + σ²I over the training points and α = (K + σ²I)⁻¹ (y − m), in
        the model's standardised units (cached)."""
        if self._cache is None:
            m = self.model
            x_train = m.train_inputs[0]
            k = m.covar_module(x_train).to_dense()
            k = k + m.likelihood.noise.reshape(-1)[0] * torch.eye(k.shape[-1], dtype=k.dtype)
            from linear_operator.utils.cholesky import psd_safe_cholesky

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                chol = psd_safe_cholesky(k, max_tries=6)  # a growing jitter where two points coincide
            resid = (m.train_targets - m.mean_module.constant).unsqueeze(-1)
            self._cache = (chol, torch.cholesky_solve(resid, chol))
        return self._cache

    def latent(self, x: np.ndarray, observation_noise: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and s.d. of the *transformed* distance at ``x`` shape (m, d) → two (m,)
        arrays. Marginal variances only — k(x, x) − k(x, X)(K + σ²I)⁻¹k(X, x) per point, never
        the joint covariance of the points asked for (BoTorch's posterior builds it: a 201² map
        needed more than 24 GB). With ``observation_noise`` the s.d. is that of a new evaluation,
        else that of the mean."""
        xs = np.atleast_2d(np.asarray(x, dtype=float))
        if xs.shape[0] == 0:
            return np.zeros(0), np.zeros(0)
        m = self.model
        chol, alpha = self._solved()
        x_train = m.train_inputs[0]
        y_mean = m.outcome_transform.means.reshape(-1)[0]
        y_sd = m.outcome_transform.stdvs.reshape(-1)[0]
        noise = m.likelihood.noise.reshape(-1)[0]
        means, sds = [], []
        with torch.no_grad():
            for start in range(0, xs.shape[0], PREDICT_CHUNK):
                tx = torch.as_tensor(xs[start:start + PREDICT_CHUNK], dtype=DTYPE)
                k_star = m.covar_module(tx, x_train).to_dense()  # (c, n)
                mean = m.mean_module.constant + (k_star @ alpha).squeeze(-1)
                v = torch.linalg.solve_triangular(chol, k_star.T, upper=False)
                var = m.covar_module(tx, diag=True) - (v * v).sum(0)
                if observation_noise:
                    var = var + noise
                # back from standardised −transform(d) to transform(d)
                means.append(-(mean * y_sd + y_mean).numpy())
                sds.append((var.clamp_min(0).sqrt() * y_sd).numpy())
        return np.concatenate(means), np.concatenate(sds)

    def covariance(self, xa: np.ndarray, xb: np.ndarray) -> np.ndarray:
        """Posterior covariance of the transformed distance's mean between ``xa[i]`` and ``xb[i]``,
        both shape (m, d) → (m,): k(a, b) − k(a, X)(K + σ²I)⁻¹k(X, b), pair by pair."""
        m = self.model
        chol, _ = self._solved()
        x_train = m.train_inputs[0]
        y_sd = m.outcome_transform.stdvs.reshape(-1)[0]
        with torch.no_grad():
            ta = torch.as_tensor(np.atleast_2d(xa), dtype=DTYPE)
            tb = torch.as_tensor(np.atleast_2d(xb), dtype=DTYPE)
            va = torch.linalg.solve_triangular(chol, m.covar_module(x_train, ta).to_dense(), upper=False)
            vb = torch.linalg.solve_triangular(chol, m.covar_module(x_train, tb).to_dense(), upper=False)
            cov = m.covar_module(ta, tb, diag=True) - (va * vb).sum(0)
        return (cov * y_sd**2).numpy()

    def noise_sd(self) -> float:
        """The fitted noise s.d. of one evaluation, in the transformed distance's units."""
        m = self.model
        return float(m.likelihood.noise.detach().reshape(-1)[0].sqrt() * m.outcome_transform.stdvs.reshape(-1)[0])

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted distance and its standard deviation at ``x`` shape (m, d) → two arrays (m,).
        Through ``log1p`` the distance is the back-transformed mean (the median of a log-normal
        prediction) and the s.d. the delta method's, (1 + d)·s."""
        mean, sd = self.latent(x)
        dist = _inverse(mean, self.transform)
        if self.transform == "log1p":
            sd = (1.0 + dist) * sd
        return dist, sd

    def to_model_units(self, distance: float) -> float:
        """A distance in the model's transformed units (to compare with :meth:`latent`)."""
        return float(_forward(np.asarray([distance], dtype=float), self.transform)[0])

    def best_posterior_mean(self) -> float:
        """The best (largest) posterior mean of −transform(d) over the evaluated points: the
        incumbent of a noisy search, where the best *observation* is a lucky seed."""
        with torch.no_grad():
            return float(self.model.posterior(self.train_x).mean.max())

    def hyperparameters(self) -> dict[str, object]:
        """Length scales (unit-cube units), output scale, noise (standardised units), for the store."""
        m = self.model
        base = getattr(m.covar_module, "base_kernel", None)
        if base is None:  # the autoregressive fidelity kernel
            ls = m.covar_module.target_lengthscales()
            extra = m.covar_module.describe()
        elif hasattr(base, "kernels"):  # the multi-fidelity model: the unbiased part's length scales
            fidelity = base.kernels[0]
            ls = fidelity.covar_module_unbiased.lengthscale.detach().reshape(-1).tolist()
            extra = {"kernel": "matern52_ard_x_linear_truncated_fidelity",
                     "bias_lengthscales": [float(v) for v in
                                           fidelity.covar_module_biased.lengthscale.detach().reshape(-1).tolist()],
                     "fidelity_power": float(fidelity.power.detach().reshape(-1)[0])}
        else:
            ls = base.lengthscale.detach().reshape(-1).tolist()
            extra = {"kernel": "matern52_ard"}
        out = {
            **extra,
            "transform": self.transform,
            "lengthscales": [float(v) for v in ls],
            "outputscale": float((m.covar_module.outputscale if hasattr(m.covar_module, "outputscale")
                                  else m.covar_module.cheap.outputscale).detach()),
            "noise": float(m.likelihood.noise.detach().reshape(-1)[0]),
            "noise_floor": float(self.noise_floor),
            "n_train": int(self.train_x.shape[0]),
        }
        return {k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in out.items()}
