"""Reading the YAML files a user writes (campaign files, experiment headers), strictly.

``yaml.safe_load`` accepts two things a user never means: a key given twice in one mapping (the
last silently wins, so half a ``parameters:`` block vanishes) and nesting thousands deep (the
composer recurses and dies in a RecursionError). :func:`read_yaml` reads with a
:class:`yaml.SafeLoader` subclass that refuses both, and turns every reading problem into a
:class:`~calibrax.errors.ConfigError` naming the file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from calibrax.errors import ConfigError

#: deepest nesting accepted; a campaign file needs four or five levels
MAX_DEPTH = 64
_MERGE_TAG = "tag:yaml.org,2002:merge"


class RefusedYAML(yaml.YAMLError):
    """Valid YAML that calibrax refuses; the message is complete (no marks appended)."""


class StrictLoader(yaml.SafeLoader):
    """A safe loader that refuses duplicate mapping keys and nesting deeper than :data:`MAX_DEPTH`."""

    def __init__(self, stream: Any) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> yaml.Node:
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                line = self.peek_event().start_mark.line + 1
                raise RefusedYAML(f"is nested deeper than {MAX_DEPTH} levels (at line {line}); "
                                  "a calibrax file needs only a few levels")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        """As SafeLoader's, after checking that no key is given twice. Keys brought in by a merge
        (``<<: *anchor``) may be overridden: only the keys written in the mapping are compared."""
        first_line: dict[Any, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == _MERGE_TAG:
                continue
            key, line = self.construct_object(key_node, deep=deep), key_node.start_mark.line + 1
            try:
                hash(key)
            except TypeError:  # an unhashable key: SafeLoader refuses it with its own message
                continue
            if key in first_line:
                raise RefusedYAML(f"duplicate key {key!r} at line {line} (first at line {first_line[key]}); "
                                  "a key may appear only once in a mapping: remove or merge one of them")
            first_line[key] = line
        return super().construct_mapping(node, deep=deep)


def _load(text: str) -> Any:
    """The single document in ``text``, read by a :class:`StrictLoader` (a safe loader: plain data
    only, never Python objects)."""
    loader = StrictLoader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def read_yaml(path: Path, error: type[ConfigError] = ConfigError) -> Any:
    """The parsed content of the YAML file ``path``; any problem is an ``error`` naming the file."""
    try:
        return _load(path.read_text(encoding="utf-8"))
    except RefusedYAML as exc:
        raise error(str(path), str(exc)) from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise error(str(path), f"is not valid YAML: {exc}") from None
    except RecursionError:  # MAX_DEPTH should stop it first; never a traceback
        raise error(str(path), "is nested too deeply; a calibrax file needs only a few levels") from None
