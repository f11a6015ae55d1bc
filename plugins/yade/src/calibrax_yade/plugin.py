"""calibrax plugin entry point: registers :class:`YadeSimulator`."""

from calibrax.plugins.hookspecs import hookimpl

from .simulator import YadeSimulator


@hookimpl
def calibrax_simulators() -> list[type]:
    """The simulators of this package."""
    return [YadeSimulator]
