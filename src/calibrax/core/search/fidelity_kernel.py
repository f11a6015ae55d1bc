"""Kennedy and O'Hagan's autoregressive co-Kriging as one kernel over (x, s).

The cheapest level is a Gaussian process g(x); the target is ρ·g(x) + δ(x), δ an independent
process (the cheap level's bias, its own length scales and variance). A level s in [0, 1] between
them is the blend (1 + (ρ − 1)s)·g(x) + s·δ(x), so that

    k((x, s), (x', s')) = a(s) a(s') k_g(x, x') + s s' k_δ(x, x'),   a(s) = 1 + (ρ − 1) s,

with k_g and k_δ scaled Matérn-5/2 kernels with one length scale per parameter (ARD), and ρ a
fitted scalar with a Normal(1, 0.5) prior (Kennedy & O'Hagan 2000, *Biometrika* 87:1; with two
levels this is exactly their model; with three or more, the middle ones are the blend).
"""

from __future__ import annotations

import torch
from gpytorch.kernels import Kernel, MaternKernel, ScaleKernel
from gpytorch.priors import GammaPrior, NormalPrior


class AutoregressiveFidelityKernel(Kernel):
    """k((x, s), (x', s')) of the module's doc; inputs (…, n, d + 1), the level last."""

    def __init__(self, dim: int) -> None:
        super().__init__()
        self.dim = dim
        active = tuple(range(dim))

        def matern() -> ScaleKernel:
            return ScaleKernel(MaternKernel(nu=2.5, ard_num_dims=dim, active_dims=active,
                                            lengthscale_prior=GammaPrior(3.0, 6.0)),
                               outputscale_prior=GammaPrior(2.0, 0.15))

        self.cheap = matern()
        self.bias = matern()
        self.register_parameter("rho", torch.nn.Parameter(torch.tensor(1.0, dtype=torch.float64)))
        self.register_prior("rho_prior", NormalPrior(1.0, 0.5), lambda m: m.rho)

    def forward(self, x1: torch.Tensor, x2: torch.Tensor, diag: bool = False, **params) -> torch.Tensor:
        s1, s2 = x1[..., -1], x2[..., -1]
        a1, a2 = 1.0 + (self.rho - 1.0) * s1, 1.0 + (self.rho - 1.0) * s2
        kg = self.cheap(x1, x2, diag=diag)
        kd = self.bias(x1, x2, diag=diag)
        if diag:
            return a1 * a2 * kg + s1 * s2 * kd
        kg, kd = kg.to_dense(), kd.to_dense()
        return a1.unsqueeze(-1) * a2.unsqueeze(-2) * kg + s1.unsqueeze(-1) * s2.unsqueeze(-2) * kd

    def target_lengthscales(self) -> list[float]:
        """Length scales of the target's own part (the cheap level's, through ρ)."""
        return [float(v) for v in self.cheap.base_kernel.lengthscale.detach().reshape(-1)]

    def describe(self) -> dict[str, object]:
        """The fitted hyperparameters for the store."""
        return {"kernel": "matern52_ard_ar1_fidelity", "rho": float(self.rho.detach()),
                "bias_lengthscales": [float(v) for v in self.bias.base_kernel.lengthscale.detach().reshape(-1)],
                "bias_outputscale": float(self.bias.outputscale.detach())}
