"""The Simulator protocol: what a DEM backend implements.

A backend is a class with a ``name``, a ``capabilities()`` set and ``simulate(spec, workdir)``.
It is registered by a plugin through the ``calibrax_simulators`` hook (see
:mod:`calibrax.core.hookspecs`). The core never imports a backend.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol, runtime_checkable

from calibrax.core.sheartest.fields import declared_fields, get_path
from calibrax.core.sheartest.result import ShearTestResult
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.errors import ConfigError

#: Effects a backend may declare in ``capabilities()``; a spec that uses an effect the backend
#: lacks is refused by :func:`check_capabilities` before anything runs.
#: (``compressibility_test``: the FT4's compressibility ramp, procedure.compressibility_stresses;
#: ``sector``: a periodic sector of the cell, geometry.sector; ``branched_steps``: every shear step
#: from a copy of one presheared bed, procedure.branches; ``cuda``: stepping on a CUDA GPU,
#: numerics.device)
KNOWN_CAPABILITIES = frozenset({"wall_friction", "size_distribution", "cohesion", "base_ribs", "rolling_friction",
                                "compressibility_test", "sector", "branched_steps", "cuda"})


@runtime_checkable
class Simulator(Protocol):
    """A DEM backend that runs one FT4 shear test.

    ``simulate`` must be deterministic for a given spec (seed included) and thread count, write
    anything it needs under ``workdir`` only, and raise
    :class:`calibrax.errors.SimulationFailed` (with the engine's log tail) on a crash, a NaN, a
    blow-up or a timeout.

    A backend may also define ``check_machine(spec)``, raising
    :class:`calibrax.errors.SpecError` naming the field when this machine cannot run ``spec`` (a
    GPU asked for, none here); a campaign whose simulations run locally calls it before anything
    runs.
    """

    name: str

    def capabilities(self) -> frozenset[str]:
        """The optional effects this backend can model (subset of ``KNOWN_CAPABILITIES``)."""
        ...

    def version(self) -> str:
        """Engine name and version, e.g. ``"LIGGGHTS 3.8.0"``."""
        ...

    def simulate(self, spec: ShearCellSpec, workdir: Path) -> ShearTestResult:
        """Run the whole test (fill, then preshear/shear for every step) and return its result."""
        ...


def capability_fields(spec: ShearCellSpec) -> dict[str, str]:
    """The optional effects a spec switches on, each with the first field that switches it on:
    the declared capability of every field whose value is not its "off" value
    (:class:`~calibrax.core.sheartest.fields.FieldInfo`), e.g. ``{"sector": "geometry.sector"}``."""
    need: dict[str, str] = {}
    for path, info in declared_fields(type(spec)):
        if info.capability is None:
            continue
        value = get_path(spec, path)
        if isinstance(value, (list, tuple)):
            value = tuple(value)
        if value != info.off:
            need.setdefault(info.capability, path)
    return need


def required_capabilities(spec: ShearCellSpec) -> set[str]:
    """The optional effects a spec switches on (:func:`capability_fields`)."""
    return set(capability_fields(spec))


def check_capabilities(simulator: Simulator, spec: ShearCellSpec) -> None:
    """Refuse a spec that asks for an effect the backend cannot model, naming the spec's field
    (``cell.geometry.sector``) that asks for it."""
    need = capability_fields(spec)
    missing = sorted(set(need) - set(simulator.capabilities()))
    if missing:
        raise ConfigError(f"cell.{need[missing[0]]}",
                          f"{simulator.name} cannot model {missing} (set by "
                          f"{', '.join('cell.' + need[m] for m in missing)}); it models "
                          f"{sorted(simulator.capabilities())}")
