"""calibrax-numba-dem: the in-house Numba DEM backend of calibrax (Hertz–Mindlin, tangential
history, EPSD2 rolling resistance, optional SJKR cohesion; analytic FT4 shear cell)."""

import os as _os
import sys as _sys
from pathlib import Path as _Path

__version__ = "0.1.0"


def _private_kernel_cache() -> None:
    """Keep the compiled kernels in a folder named by the sources' key (:mod:`.cache_key`) when the
    caller has not chosen one (``make`` and the test suite set NUMBA_CACHE_DIR themselves).

    Numba checks a cached kernel against its own file only, not the files it inlines from, so its
    default cache beside the sources can serve stale kernels (what that cost once:
    docs/how-to/run-the-tests.md, "The compiled kernels"). Set before any kernel is defined;
    inherited by the simulations' processes."""
    if _os.environ.get("NUMBA_CACHE_DIR"):
        return
    from .cache_key import cache_key

    base = _Path(_os.environ.get("XDG_CACHE_HOME") or _Path.home() / ".cache")
    folder = str(base / "calibrax" / "numba" / cache_key())
    _os.environ["NUMBA_CACHE_DIR"] = folder
    if "numba" in _sys.modules:  # imported before us: its config has read the environment already
        _sys.modules["numba"].config.CACHE_DIR = folder


_private_kernel_cache()

from .simulator import NumbaDEMSimulator  # noqa: E402

__all__ = ["NumbaDEMSimulator", "__version__"]
