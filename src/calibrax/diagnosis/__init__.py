"""``calibrax diagnose``: where the sim-to-real gap lies, which unmodelled effect causes it, and how
far it shrinks once that effect is added (docs/explanation/diagnosis.md).

It reaches simulators only through the Simulator protocol and ``capabilities()``, and runs its
simulations through the study machinery, so it resumes and scales like a campaign. The library
API::

    from calibrax.diagnosis import Calibrated, diagnose, effects_by_name
    calibrated = Calibrated.from_store("runs/campaign.h5")
    result = diagnose(calibrated, effects_by_name(["wall_friction", "cohesion"]), "runs/campaign.diagnosis",
                      executor)
    print(result.verdict, result.shrinkage)
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from calibrax.diagnosis.design import Budget
    from calibrax.diagnosis.effects import Effect, EffectParameter, LogUniformPrior, TruncatedNormalPrior, UniformPrior
    from calibrax.diagnosis.run import Calibrated, Diagnosis, diagnose

__all__ = ["Budget", "Calibrated", "Diagnosis", "Effect", "EffectParameter", "LogUniformPrior", "TruncatedNormalPrior",
           "UniformPrior",
           "diagnose", "effects_by_name"]

#: the public names and their modules, imported on first use (PEP 562): every simulation process
#: loads the effect plugins of ``calibrax.diagnosis.effects``, and the rest of the diagnosis (SciPy's
#: statistics among it, about a second) is not needed there
_LAZY = {"Budget": "design", "Effect": "effects", "EffectParameter": "effects", "LogUniformPrior": "effects",
         "TruncatedNormalPrior": "effects",
         "UniformPrior": "effects", "Calibrated": "run", "Diagnosis": "run", "diagnose": "run"}


def __getattr__(name: str) -> object:
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"calibrax.diagnosis.{_LAZY[name]}"), name)


def effects_by_name(names: list[str] | None = None) -> list[Effect]:
    """The registered effects of these names (all of them for None), each built with no arguments;
    an unknown name is a ConfigError naming ``--effects`` and listing the known ones."""
    from calibrax.errors import ConfigError
    from calibrax.core.registry import get_manager

    known = get_manager().plugins("effect")
    if names is None:
        return [info.cls() for _, info in sorted(known.items(), key=lambda kv: _ORDER.get(kv[0], 99))]
    bad = [n for n in names if n not in known]
    if bad or not names or len(set(names)) != len(names):
        raise ConfigError("--effects", f"unknown or repeated effect(s) {bad or names}; known: {sorted(known)}")
    return [known[n].cls() for n in names]


_ORDER = {"wall_friction": 0, "size_distribution": 1, "cohesion": 2}
