"""The one exception hierarchy of calibrax.

Every error a user can meet is a :class:`CalibraxError`; its message says what
is wrong *and* what to do about it. The CLI turns :class:`ConfigError` (and
other user-input errors) into exit code 2 and prints only the message.
"""

from __future__ import annotations

from enum import StrEnum


class FailureKind(StrEnum):
    """What kind of failure a :class:`SimulationFailed` is (stored as its text)."""

    CRASH = "crash"  #: the engine or its process died, or raised
    NAN = "nan"  #: NaN in the state or the result
    TIMEOUT = "timeout"  #: ran past its time limit
    UNSTABLE = "unstable"  #: blew up, or particles left the cell
    INVALID = "invalid"  #: the result cannot mean anything (wrong shape, no step)
    WORKER_LOST = "worker_lost"  #: the cluster lost the worker (infrastructure, not the parameters)
    CANCELLED = "cancelled"  #: the campaign stopped it (infrastructure, not the parameters)

    @property
    def is_physical(self) -> bool:
        """Whether the failure says something about the parameters (the search should avoid them)."""
        return self not in (FailureKind.WORKER_LOST, FailureKind.CANCELLED)



class CalibraxError(Exception):
    """Base class of every calibrax error."""

    exit_code: int = 1


class ConfigError(CalibraxError, ValueError):
    """A campaign file, a spec or an experiment file is invalid.

    ``key`` is the dotted path of the offending key (``"parameters.youngs_modulus.low"``)
    or the file name; the message states what is allowed.
    """

    exit_code = 2

    def __init__(self, key: str, message: str) -> None:
        self.key = key
        self.message = message
        super().__init__(f"{key}: {message}" if key else message)

    def __reduce__(self):  # survive pickling across processes (Dask workers, simulation processes)
        return (type(self), (self.key, self.message))


class SpecError(ConfigError):
    """A :class:`~calibrax.core.sheartest.ShearCellSpec` is physically invalid."""


class ExperimentError(ConfigError):
    """An experiment file is missing, malformed or has too few points."""


class PluginError(CalibraxError):
    """A plugin is unknown, broken, or does not implement its interface."""

    exit_code = 2


class SimulationFailed(CalibraxError):
    """A simulation crashed, returned NaN, blew up or ran past its timeout.

    A failed simulation is *data*: the campaign records ``reason`` and
    ``log_tail`` (the last lines of the engine's own log) and goes on.
    """

    def __init__(self, reason: str, log_tail: str = "", *, kind: FailureKind | str = FailureKind.CRASH) -> None:
        self.reason = reason
        self.log_tail = log_tail
        try:
            self.kind = FailureKind(kind)
        except ValueError:
            raise ValueError(f"unknown failure kind {kind!r}; allowed: {[k.value for k in FailureKind]}") from None
        super().__init__(reason)

    def __reduce__(self):
        return (_rebuild_simulation_failed, (type(self), self.reason, self.log_tail, self.kind))

    @property
    def is_physical(self) -> bool:
        """True when the failure says something about the parameters (the search should avoid them),
        False when it was the infrastructure (a lost worker, a cancellation)."""
        return self.kind.is_physical


def _rebuild_simulation_failed(cls: type, reason: str, log_tail: str, kind: str) -> "SimulationFailed":
    return cls(reason, log_tail, kind=kind)


class StoreError(CalibraxError):
    """The campaign store cannot be read, written, locked, or does not match the config."""

    exit_code = 2


class StoreLockedError(StoreError):
    """Another campaign holds the store."""


class EngineNotFound(CalibraxError):
    """A backend's engine binary is not installed; the message says how to install it."""

    exit_code = 2


class DiagnosisError(CalibraxError):
    """A diagnosis cannot go on: its campaign has no answer yet, or too few of its simulations
    finished to fit the candidates."""
