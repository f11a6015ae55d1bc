"""calibrax plugin entry point: registers :class:`LiggghtsSimulator`."""

from calibrax.core.hookspecs import hookimpl

from .simulator import LiggghtsSimulator


@hookimpl
def calibrax_simulators() -> list[type]:
    """The simulators of this package."""
    return [LiggghtsSimulator]


@hookimpl
def calibrax_verifications() -> list[type]:
    """The analytic checks of this package's simulator (calibrax crosscheck's micro level)."""
    from .verification import LiggghtsVerification

    return [LiggghtsVerification]
