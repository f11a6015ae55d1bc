"""calibrax-yade: the YADE backend of calibrax (Hertz–Mindlin with restitution damping and
rolling moments, facet FT4 cell, stress-servoed bladed head), run through the ``yade`` binary."""

__version__ = "0.1.0"

from .simulator import YadeSimulator  # noqa: E402

__all__ = ["YadeSimulator", "__version__"]
