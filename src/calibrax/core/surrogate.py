"""The Kriging surrogate: a GPyTorch Gaussian process through BoTorch.

``SingleTaskGP`` with a Matérn-5/2 kernel and one length scale per parameter (ARD), on inputs
already in the unit cube (log-scaled where the parameter is), outcomes standardised, and a fitted
Gaussian noise because DEM is stochastic. BoTorch *maximises*, so the model is fitted to the
negated distance; :meth:`Kriging.predict` gives the distance back.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import torch

DTYPE = torch.float64


@dataclass
class Kriging:
    """A fitted GP model of −distance over the unit cube. ``model`` is the BoTorch model."""

    model: object
    train_x: torch.Tensor
    train_y: torch.Tensor  # shape (n, 1): −distance

    @classmethod
    def fit(cls, x: np.ndarray, distance: np.ndarray, seed: int = 0) -> "Kriging":
        """Fit on ``x`` shape (n, d) in [0, 1]^d and ``distance`` shape (n,). Needs n ≥ 2."""
        from botorch.fit import fit_gpytorch_mll
        from botorch.models import SingleTaskGP
        from botorch.models.transforms.outcome import Standardize
        from gpytorch.kernels import MaternKernel, ScaleKernel
        from gpytorch.mlls import ExactMarginalLogLikelihood
        from gpytorch.priors import GammaPrior

        torch.manual_seed(seed)
        tx = torch.as_tensor(np.asarray(x, dtype=float), dtype=DTYPE)
        ty = -torch.as_tensor(np.asarray(distance, dtype=float), dtype=DTYPE).reshape(-1, 1)
        d = tx.shape[-1]
        # The classic Kriging priors of BoTorch's legacy default: keep length scales O(0.1–1) of the
        # cube when only a handful of points is known.
        covar = ScaleKernel(MaternKernel(nu=2.5, ard_num_dims=d, lengthscale_prior=GammaPrior(3.0, 6.0)),
                            outputscale_prior=GammaPrior(2.0, 0.15))
        model = SingleTaskGP(tx, ty, covar_module=covar, outcome_transform=Standardize(m=1))
        mll = ExactMarginalLogLikelihood(model.likelihood, model)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                fit_gpytorch_mll(mll)
            except Exception:  # noqa: BLE001 — a failed hyperparameter fit keeps the priors' mode
                pass
        model.eval()
        return cls(model, tx, ty)

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted distance and its standard deviation at ``x`` shape (m, d) → two arrays (m,)."""
        tx = torch.as_tensor(np.atleast_2d(np.asarray(x, dtype=float)), dtype=DTYPE)
        with torch.no_grad():
            post = self.model.posterior(tx)
            mean = -post.mean.squeeze(-1).numpy()
            std = post.variance.clamp_min(0).sqrt().squeeze(-1).numpy()
        return mean, std

    def hyperparameters(self) -> dict[str, object]:
        """Length scales (unit-cube units), output scale, noise (standardised units), for the store."""
        m = self.model
        ls = m.covar_module.base_kernel.lengthscale.detach().reshape(-1).tolist()
        out = {
            "kernel": "matern52_ard",
            "lengthscales": [float(v) for v in ls],
            "outputscale": float(m.covar_module.outputscale.detach()),
            "noise": float(m.likelihood.noise.detach().reshape(-1)[0]),
            "n_train": int(self.train_x.shape[0]),
        }
        return {k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in out.items()}
