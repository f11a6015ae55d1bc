"""What the spec declares about each of its fields, once: unit, symbol, allowed range, whether a
campaign may calibrate it, and the backend capability a value other than its "off" value needs.

The spec's dataclasses (:mod:`calibrax.core.sheartest.spec`) attach a :class:`FieldInfo` to a
field with :func:`declared`; validation (:mod:`~calibrax.core.sheartest.validation`), the
calibratable parameters (:mod:`calibrax.core.search.parameters`), the capabilities a spec needs
(:func:`calibrax.core.simulator.required_capabilities`) and the reference table of the docs
(``docs/hooks/spec_fields.py``) all read it from there. A field is named by its dotted path from
the spec, ``group.field`` (``material.sliding_friction``, ``geometry.wall_friction``) or ``field``
for the spec's own (``radius``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Iterator

from calibrax.core.options import Interval
from calibrax.errors import SpecError

#: the key of a dataclass field's metadata that holds its :class:`FieldInfo`
METADATA_KEY = "calibrax"
#: the spec's groups whose numeric fields a campaign may calibrate (the model of the powder and of
#: the cell's surfaces); the procedure and the numerics define the test, not the model
CALIBRATABLE_GROUPS = ("material", "geometry", "size_distribution")


@dataclass(frozen=True)
class FieldInfo(Interval):
    """One declared field.

    Attributes:
        unit: its SI unit ("-" dimensionless, "" for a field that is not a number).
        symbol: the symbol answers, logs, figures and tables show (``E``, ``μs``).
        low, high: the allowed range, natural units; ``low_open``/``high_open`` exclude the end.
        integer: the value must be an int.
        optional: ``None`` is allowed (it means "derived": see the field's docstring).
        calibratable: a campaign may calibrate it (a float in :data:`CALIBRATABLE_GROUPS`).
        display_scale, display_unit: what the value is multiplied by for display, and the unit
            then (E shown in GPa: 1e-9, "GPa"); 1 and ``unit`` by default.
        capability: the backend capability (:data:`calibrax.core.simulator.KNOWN_CAPABILITIES`)
            that a value other than ``off`` needs; None: any backend runs it.
        off: the value that needs no capability.
    """

    unit: str = "-"
    symbol: str = ""
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    integer: bool = False
    optional: bool = False
    calibratable: bool = False
    display_scale: float = 1.0
    display_unit: str = ""
    capability: str | None = None
    off: Any = None

    @property
    def numeric(self) -> bool:
        """Whether the field holds one number (its range is checked)."""
        return self.unit != ""

    def check(self, key: str, value: Any) -> None:
        """Raise :class:`SpecError` naming ``key`` and what is allowed unless ``value`` is a valid
        value of this field."""
        if not self.numeric or (value is None and self.optional):
            return
        if self.integer:
            if not isinstance(value, int) or isinstance(value, bool) or not self.contains(value):
                raise SpecError(key, f"must be an integer {self.interval()}, got {value!r}")
            return
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            raise SpecError(key, f"must be a finite number, got {value!r}")
        if not self.contains(value):
            verb = "must be" if math.isinf(self.high) else "must lie"
            raise SpecError(key, f"{verb} {self.interval()}, got {value!r}")


def declared(default: Any = dataclasses.MISSING, *, default_factory: Any = dataclasses.MISSING,
             **info: Any) -> Any:
    """A dataclass field with its :class:`FieldInfo` (keyword arguments) in its metadata."""
    return dataclasses.field(default=default, default_factory=default_factory,
                             metadata={METADATA_KEY: FieldInfo(**info)})


def info_of(field: dataclasses.Field) -> FieldInfo | None:
    """The :class:`FieldInfo` a dataclass field declares, or None."""
    return field.metadata.get(METADATA_KEY)


def declared_fields(spec_type: type) -> Iterator[tuple[str, FieldInfo]]:
    """(dotted path, info) of every declared field of the spec class ``spec_type`` and of its
    dataclass groups, in declaration order."""
    for field in dataclasses.fields(spec_type):
        info = info_of(field)
        if info is not None:
            yield field.name, info
        group_type = field.default_factory if field.default_factory is not dataclasses.MISSING else None
        if isinstance(group_type, type) and dataclasses.is_dataclass(group_type):
            for sub in dataclasses.fields(group_type):
                sub_info = info_of(sub)
                if sub_info is not None:
                    yield f"{field.name}.{sub.name}", sub_info


def get_path(spec: Any, path: str) -> Any:
    """The value at dotted ``path`` of ``spec``."""
    value = spec
    for part in path.split("."):
        value = getattr(value, part)
    return value


def set_paths(spec: Any, values: dict[str, Any]) -> Any:
    """``spec`` with each dotted path of ``values`` set (``{"geometry.wall_friction": 0.3}``), by
    the spec's own ``replace`` (which refuses an unknown field, naming it). The campaign's points
    and the diagnosis's effects both set the spec this way."""
    groups: dict[str, dict[str, Any]] = {}
    top: dict[str, Any] = {}
    for path, value in values.items():
        group, _, name = path.rpartition(".")
        if group:
            groups.setdefault(group, {})[name] = value
        else:
            top[name] = value
    return spec.replace(**groups, **top) if groups or top else spec
