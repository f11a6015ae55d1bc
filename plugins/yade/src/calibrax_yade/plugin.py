"""calibrax plugin entry point: registers :class:`YadeSimulator`."""

from calibrax.core.hookspecs import hookimpl

from .simulator import YadeSimulator


@hookimpl
def calibrax_simulators() -> list[type]:
    """The simulators of this package."""
    return [YadeSimulator]
