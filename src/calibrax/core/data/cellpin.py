"""Which cell made a pseudo-experiment, pinned, and whether its preset still resolves the same.

A pseudo-experiment's header names its preset (``cell: {preset: tiny}``), and presets change:
``tiny`` once preshearing a fixed 0.12 rad now preshears to a steady state. Data made with the
former cell are data of another procedure, and a diagnosis or a campaign reading them as today's
``tiny`` would take the procedure's difference for the powder's. So the header pins the cell as
resolved when the data were made (:func:`cell_pin`): the fields a preset decides (geometry,
procedure, numerics: ``PINNED_SECTIONS``, less the seed, the threads and the effects' fields,
``UNPINNED``), their hash, the calibrax version, and which of them the maker set apart from the
preset (``overrides``: never the preset's, so never stale). :func:`stale_fields` compares a header's
pin with what its preset resolves to now, field by field.
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any

from calibrax.core.sheartest.spec import ShearCellSpec

#: the spec's sections a fidelity preset decides
PINNED_SECTIONS = ("geometry", "procedure", "numerics")
#: fields of those sections that are not the cell's: the replicate's seed, the machine's threads,
#: and the lateral wall's friction, which is an effect the diagnosis may switch on
UNPINNED = frozenset({"numerics.seed", "numerics.threads", "geometry.wall_friction", "geometry.wall_rolling_friction"})


def resolved_fields(spec: ShearCellSpec) -> dict[str, Any]:
    """The cell's pinned fields, dotted (``procedure.preshear_rotation``), JSON values."""
    data = spec.to_dict()
    return {f"{section}.{name}": value for section in PINNED_SECTIONS for name, value in sorted(data[section].items())
            if f"{section}.{name}" not in UNPINNED}


def fields_hash(fields: dict[str, Any]) -> str:
    """A short stable hash of pinned fields."""
    return hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:16]


def _preset_now(preset: str, radius: float) -> ShearCellSpec | None:
    from calibrax.core.sheartest.presets import FIDELITY_PRESETS

    return ShearCellSpec.preset(preset, radius=radius) if preset in FIDELITY_PRESETS else None


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-15)
    return json.dumps(a) == json.dumps(b)


def _added_at_default(key: str, value: Any) -> bool:
    """A field added to the spec after the pin was written, at the default that keeps former specs'
    behaviour (:data:`~calibrax.core.sheartest.spec.ADDED_SPEC_FIELDS`)."""
    from calibrax.core.sheartest.spec import ADDED_SPEC_FIELDS

    group, _, name = key.partition(".")
    return (group, name) in ADDED_SPEC_FIELDS and _same(value, json.loads(json.dumps(ADDED_SPEC_FIELDS[group, name])))


def cell_pin(spec: ShearCellSpec) -> dict[str, Any]:
    """What a pseudo-experiment's header records of the cell that made it (see the module docstring):
    ``preset``, ``radius_m``, ``calibrax_version``, ``resolved`` (the pinned fields), ``resolved_hash``
    and ``overrides`` (the pinned fields where the spec differs from its preset as resolved then)."""
    from calibrax import __version__

    fields = resolved_fields(spec)
    preset = _preset_now(spec.name, spec.radius)
    then = resolved_fields(preset) if preset is not None else {}
    overrides = sorted(k for k, v in fields.items() if k not in then or not _same(v, then[k]))
    return {"preset": spec.name, "radius_m": spec.radius, "calibrax_version": __version__, "resolved_hash":
            fields_hash(fields), "overrides": overrides, "resolved": fields}


def stale_fields(cell: dict[str, Any], made: bool = True) -> list[str]:
    """The header's ``cell`` against its preset as it resolves now: one line per pinned field that
    changed (``cell.resolved.procedure.preshear_rotation: 0.12 when made (calibrax 0.4), 0.3 now``);
    for made data (``made``: a pseudo-experiment), one line naming ``cell.resolved`` where a known
    preset was recorded without its fields (made before cells were pinned), so nothing can be
    checked; empty where it resolves the same, the cell is not a preset's, or measured data name
    a preset for the record."""
    preset = cell.get("preset")
    if not isinstance(preset, str):
        return []
    resolved = cell.get("resolved")
    radius = cell.get("radius_m")
    now = _preset_now(preset, float(radius) if isinstance(radius, (int, float)) else 0.9e-3)
    if now is None:
        return []
    if not isinstance(resolved, dict):
        if not made:
            return []
        return [f"cell.resolved: missing, so the preset {preset!r} it names cannot be checked: the data were made "
                f"before cells were pinned, with {preset!r} as it resolved then, which may not be {preset!r} now"]
    version = cell.get("calibrax_version", "unknown")
    skip = set(cell.get("overrides") or ())
    current = resolved_fields(now)
    out = []
    for key in sorted(set(resolved) | set(current)):
        if key in skip or key in UNPINNED:
            continue
        if key not in resolved and _added_at_default(key, current.get(key)):
            continue
        then_value, now_value = resolved.get(key, "absent"), current.get(key, "absent")
        if not _same(then_value, now_value):
            out.append(f"cell.resolved.{key}: {then_value!r} when made (calibrax {version}), {now_value!r} in "
                       f"{preset!r} now")
    return out
