"""calibrax-liggghts: the LIGGGHTS backend of calibrax (writes an input script and STL meshes from
a ShearCellSpec, runs the Debian ``liggghts`` binary, parses its output)."""

__version__ = "0.1.0"

from .simulator import LiggghtsSimulator  # noqa: E402

__all__ = ["LiggghtsSimulator", "__version__"]
