"""calibrax plugin entry point: registers :class:`LiggghtsSimulator`."""

from calibrax.core.hookspecs import hookimpl

from .simulator import LiggghtsSimulator


@hookimpl
def calibrax_simulators() -> list[type]:
    """The simulators of this package."""
    return [LiggghtsSimulator]
