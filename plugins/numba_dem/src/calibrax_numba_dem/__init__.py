"""calibrax-numba-dem: the in-house Numba DEM backend of calibrax (Hertz–Mindlin, tangential
history, EPSD2 rolling resistance, optional SJKR cohesion; analytic FT4 shear cell)."""

__version__ = "0.1.0"

from .simulator import NumbaDEMSimulator  # noqa: E402

__all__ = ["NumbaDEMSimulator", "__version__"]
