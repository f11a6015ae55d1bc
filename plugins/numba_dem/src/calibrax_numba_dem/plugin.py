"""calibrax plugin entry point: registers :class:`NumbaDEMSimulator`."""

from calibrax.core.hookspecs import hookimpl

from .simulator import NumbaDEMSimulator


@hookimpl
def calibrax_simulators() -> list[type]:
    """The simulators of this package."""
    return [NumbaDEMSimulator]
