"""A plugin's options, declared once and checked in one place with one message style.

A plugin class states ``OPTIONS = {"num_restarts": Option(int, low=1), "against":
Option(str, choices=("target", "measured"))}``; :func:`check_options` checks what a campaign
file or a caller gives against it (``metric.against: must be one of ['target', 'measured'],
got 'both'``), before the plugin is built (:meth:`calibrax.core.registry.PluginManager.create`
and the campaign file's parser both call it). What the plugin's ``__init__`` still checks are the
rules between its options. A plain type (``{"workers": int}``) is read as ``Option(int)``, so
third-party plugins written before declarations keep working.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from calibrax.errors import ConfigError


class Interval:
    """An allowed range ``low``–``high`` whose ends ``low_open``/``high_open`` may exclude, shared by
    an option's declaration and a spec field's (:class:`~calibrax.core.sheartest.fields.FieldInfo`)."""

    low: float
    high: float
    low_open: bool
    high_open: bool

    def interval(self) -> str:
        """The allowed range in words (``≥ 1``, ``> 0``, ``in [0, 0.5)``; "" when unbounded)."""
        if math.isinf(self.high):
            return f"{'>' if self.low_open else '≥'} {self.low:g}" if not math.isinf(self.low) else ""
        return f"in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}{')' if self.high_open else ']'}"

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in the allowed range."""
        return ((value > self.low) if self.low_open else (value >= self.low)) and \
            ((value < self.high) if self.high_open else (value <= self.high))


@dataclass(frozen=True)
class Option(Interval):
    """One option of a plugin.

    Attributes:
        type: int, float, str, list (of text) or dict (of text → number).
        low, high: the allowed range of a number (``low_open``/``high_open`` exclude the end);
            of a dict's values.
        choices: the allowed values of a text option, or of a list's items, or a dict's keys.
        nonempty: a list or dict must not be empty.
    """

    type: type
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    choices: tuple[str, ...] | None = None
    nonempty: bool = False

    def _number(self, key: str, value: Any) -> float:
        if isinstance(value, str):  # PyYAML reads 5.0e9 (no sign in the exponent) as text
            try:
                value = float(value)
            except ValueError:
                pass
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(key, f"must be a finite number{' ' + self.interval() if self.interval() else ''}, "
                              f"got {value!r}")
        if not self.contains(value):
            raise ConfigError(key, f"must be {self.interval()}, got {value!r}")
        return float(value)

    def check(self, key: str, value: Any) -> Any:
        """``value`` checked (and a number in text read as one); raises :class:`ConfigError`
        naming ``key`` and what is allowed."""
        if self.type is int:
            if isinstance(value, bool) or not isinstance(value, int) or not self.contains(value):
                raise ConfigError(key, f"must be an integer {self.interval() or ''}".rstrip() + f", got {value!r}")
            return value
        if self.type is float:
            return self._number(key, value)
        if self.type is str:
            if not isinstance(value, str) or not value.strip():
                raise ConfigError(key, f"must be non-empty text, got {type(value).__name__} {value!r}")
            if self.choices is not None and value not in self.choices:
                raise ConfigError(key, f"must be one of {list(self.choices)}, got {value!r}")
            return value
        if self.type is list:
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value) or (
                    self.nonempty and not value):
                raise ConfigError(key, f"must be a {'non-empty ' if self.nonempty else ''}list of text, got {value!r}")
            bad = [v for v in value if self.choices is not None and v not in self.choices]
            if bad:
                raise ConfigError(key, f"unknown item(s) {bad}; allowed: {list(self.choices)}")
            return list(value)
        if self.type is dict:
            if not isinstance(value, dict) or (self.nonempty and not value):
                raise ConfigError(key, f"must be a {'non-empty ' if self.nonempty else ''}mapping of names to "
                                  f"numbers, got {value!r}")
            out = {}
            for k, v in value.items():
                if self.choices is not None and k not in self.choices:
                    raise ConfigError(f"{key}.{k}", f"unknown key; allowed: {list(self.choices)}")
                out[str(k)] = self._number(f"{key}.{k}", v)
            return out
        raise TypeError(f"Option of unsupported type {self.type!r}")


def declared_options(cls: type) -> dict[str, Option]:
    """A plugin class's ``OPTIONS`` as :class:`Option` (a plain type read as ``Option(type)``)."""
    raw: Mapping[str, Any] = getattr(cls, "OPTIONS", {})
    return {name: spec if isinstance(spec, Option) else Option(spec) for name, spec in raw.items()}


def check_options(key: str, cls: type, options: Mapping[str, Any]) -> dict[str, Any]:
    """``options`` for the plugin class ``cls`` checked against its declaration: each known, each
    valid; ``key`` is the campaign file's section (``metric``, ``acquisition``, ``executor``),
    which every message names. Returns them checked (numbers in text read as numbers). ``None``
    stands for "the plugin's default" and is passed on."""
    declared = declared_options(cls)
    out = {}
    for name, value in options.items():
        if name not in declared:
            raise ConfigError(f"{key}.{name}", f"unknown option of {key} {getattr(cls, 'name', cls.__name__)!r}; "
                              f"allowed: {sorted(declared)}")
        out[name] = None if value is None else declared[name].check(f"{key}.{name}", value)
    return out
