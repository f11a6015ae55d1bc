"""The resolved config's fields that were added after stores existed, and the resolved config
without them while they hold their defaults: what the search hash (:func:`calibrax.core.config.search_identity`)
and a warm start's comparison of cells (:mod:`calibrax.core.warm_start`) read, so that a store made
before a field existed still resumes and still warm-starts."""

from __future__ import annotations

import json
from typing import Any

from calibrax.core.sheartest.spec import ADDED_SPEC_FIELDS

#: spec fields added after stores existed, with their defaults: left out of the search hash while
#: they hold them, so that a store made before the field existed still resumes
ADDED_FIELDS: dict[tuple[str, ...], Any] = {("cell", "geometry", "wall_rolling_friction"): None,
                                            **{("cell", *path): d for path, d in ADDED_SPEC_FIELDS.items()}}


def without_added_defaults(resolved: dict[str, Any]) -> dict[str, Any]:
    """A deep copy of ``resolved`` without the :data:`ADDED_FIELDS` that hold their defaults."""
    out = json.loads(json.dumps(resolved))
    for path, default in ADDED_FIELDS.items():
        *parents, last = path
        node = out
        for key in parents:
            node = node.get(key, {}) if isinstance(node, dict) else {}
        if isinstance(node, dict) and last in node and node[last] == json.loads(json.dumps(default)):
            del node[last]
    return out
