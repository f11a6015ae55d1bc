"""calibrax plugin entry point: registers :class:`YadeSimulator`."""

from calibrax.core.hookspecs import hookimpl

from .simulator import YadeSimulator


@hookimpl
def calibrax_simulators() -> list[type]:
    """The simulators of this package."""
    return [YadeSimulator]


@hookimpl
def calibrax_verifications() -> list[type]:
    """The analytic checks of this package's simulator (calibrax crosscheck's micro level)."""
    from .verification import YadeVerification

    return [YadeVerification]
