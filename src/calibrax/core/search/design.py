"""Space-filling designs over the unit cube: the campaign's initial points, the answer's grid, the
Sobol acquisition's and the fallbacks' points all come from here."""

from __future__ import annotations

import numpy as np


def sobol_points(dim: int, n: int, seed: int = 0, skip: int = 0) -> np.ndarray:
    """``n`` scrambled Sobol points in [0, 1]^dim, shape (n, dim), after skipping ``skip``."""
    import torch
    from torch.quasirandom import SobolEngine

    engine = SobolEngine(dimension=dim, scramble=True, seed=seed)
    if skip:
        engine.fast_forward(skip)
    return engine.draw(n, dtype=torch.float64).numpy()


__all__ = ["sobol_points"]
