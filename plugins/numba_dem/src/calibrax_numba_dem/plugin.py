"""calibrax plugin entry point: registers :class:`NumbaDEMSimulator`."""

from calibrax.core.hookspecs import hookimpl

from .simulator import NumbaDEMSimulator


@hookimpl
def calibrax_simulators() -> list[type]:
    """The simulators of this package."""
    return [NumbaDEMSimulator]


@hookimpl
def calibrax_verifications() -> list[type]:
    """The analytic checks of this package's simulator (calibrax crosscheck's micro level)."""
    from .verification import NumbaDEMVerification

    return [NumbaDEMVerification]
