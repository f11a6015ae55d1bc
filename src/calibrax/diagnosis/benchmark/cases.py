"""Benchmark cases: what each hidden truth is, the labels file that records it, and the blinded
experiment files a diagnosis sees.

**Classes.** A case is one of:

* a *listed* effect (one of the model's candidates) at a small, medium or large magnitude
  (:data:`MAGNITUDES`, natural units);
* ``none``: a control with no effect;
* ``unlisted``: an effect outside the candidate list alone: a different rolling friction (the
  sphere model's stand-in for particle shape, :class:`RollingFriction`). The right answer is
  "none of the candidates";
* ``mismatch``: no effect, but made with a procedure or an engine the diagnosis's model and
  design never saw (:data:`MISMATCHES`: the former fixed preshear of 0.12 rad, half, three and
  eight times the rotation rate, LIGGGHTS for numba_dem), the kind of mismatch a real instrument brings. The right answer is "none" where the mismatch
  stays inside the noise and "none of the candidates" beyond it;
* ``mismatch+listed``: such a mismatch with a listed effect at its large magnitude on top; the
  right answer names the listed effect;
* ``listed+unlisted``: a listed effect at its medium magnitude and that unlisted one together,
  each listed effect in turn (:func:`listed_and_unlisted`). The right answer names the listed
  effect and flags the gap it leaves
  (:attr:`~calibrax.diagnosis.scoring.Ranking.unexplained`); scored apart from the unlisted
  class, as "named" and "named with the gap flagged", and per listed effect: where the two
  effects' signatures cancel or a recalibrated parameter takes the unlisted one up, no
  diagnosis can flag a gap.

**Labels file** (YAML, never read by a diagnosis)::

    cases:
      - {case: c07, class: wall_friction, magnitude: medium, truth_backend: liggghts,
         params: {youngs_modulus: 2.0e10, sliding_friction: 0.35},
         effects: {wall_friction: 0.25}, expected: wall_friction}

``expected`` is the answer a perfect diagnosis gives: the effect's name, ``none``, or
``none of the candidates``; ``effects`` are the hidden values that made the case (empty for a
control). An external folder's labels need only ``case``, ``class`` and ``expected`` (and
``effects`` for the magnitude error).

**Blinded files.** Each case is an ordinary experiment (header YAML, points CSV, curves CSV; see
:mod:`calibrax.core.data.experiment`) named by its opaque id. Its header names the cell it was
measured in (preset and base) and says it is made data, but not the backend, the material or any
effect; what made it is in the labels file only.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from calibrax.diagnosis.effects import EffectParameter, UniformPrior
from calibrax.diagnosis.scoring import NO_EFFECT, NONE_OF_THEM
from calibrax.errors import ConfigError

#: the hidden magnitudes of each builtin effect, natural units (wall friction coefficient, σ of
#: ln r, Bond number at 15 kPa): small is where a tiny cell's seed noise hides it,
#: large near the top of the range the diagnosis explores
MAGNITUDES: dict[str, dict[str, float]] = {
    "wall_friction": {"small": 0.1, "medium": 0.25, "large": 0.45},
    "sigma_log": {"small": 0.1, "medium": 0.25, "large": 0.45},
    "bond_number": {"small": 0.2, "medium": 0.6, "large": 1.5},
}
#: the unlisted case's hidden truth: no rolling friction (against the model's 0.5), round particles
#: in a model calibrated with shape. Measured at tiny (E = 20 GPa, μs = 0.35, 4 seeds each,
#: benchmarks/density_tests.py): μr 0.15 lowers the mean peak τ/σ from 0.84 to 0.59 and moves no
#: density beyond 3 noise units, a change the calibrated μs takes up inside the plausible region, so
#: no diagnosis can tell it from none; μr 0 lowers it to 0.40 (−17 units of a 3-replicate mean) and
#: raises the bulk density after preshear by 83 kg/m³ (+7.7), as large as a listed effect's medium
ROLLING_FRICTION_TRUTH = 0.0
CLASS_NONE = "none"
CLASS_UNLISTED = "unlisted"
CLASS_MIXED = "listed+unlisted"
CLASS_MISMATCH = "mismatch"
CLASS_MISMATCH_LISTED = "mismatch+listed"
#: the classes that are not one listed effect alone
OTHER_CLASSES = (CLASS_NONE, CLASS_UNLISTED, CLASS_MIXED, CLASS_MISMATCH, CLASS_MISMATCH_LISTED)
#: the classes whose truth comes from a procedure the diagnosis's design never saw
MISMATCH_CLASSES = (CLASS_MISMATCH, CLASS_MISMATCH_LISTED)
#: what a mismatched truth changes: ``backend`` the engine that makes it (another engine's contact
#: laws, integration and packing), procedure fields set as given, ``rotation_rate`` as a factor on
#: the model's. The fixed preshear of 0.12 rad is what every preset ran before the steady preshear
#: (its preshears end inside the transient, docs/explanation/seed-noise.md); half the rate is a
#: slower instrument, three times it a faster one (the peaks' τ/σ still moves with the rate at
#: `quick`: README, "Convergence at quick"); eight times it multiplies the inertial number by eight
#: (`quick`'s is 0.002 at 5 rad/s: README), toward the dense-flow range where τ/σ grows with I
#: (GDR MiDi 2004, "On dense granular flows", Eur. Phys. J. E 14, 341), a mismatch well beyond the
#: noise for the benchmark's "none of the candidates"; LIGGGHTS has no compressibility ramp, so its truth
#: runs without one and takes the model's engine's compressibility and conditioned bulk density
MISMATCHES: dict[str, dict[str, Any]] = {
    "fixed_preshear": {"preshear_rotation": 0.12, "preshear_max_rotation": None},
    "slow_rate": {"rotation_rate": 0.5},
    "fast_rate": {"rotation_rate": 3.0},
    "inertial_rate": {"rotation_rate": 8.0},
    "liggghts": {"backend": "liggghts", "compressibility_stresses": ()},
}


def mismatch_backend(kind: str, backend: str) -> str:
    """The engine that makes a truth of mismatch ``kind`` (``backend``: the model's)."""
    return str(MISMATCHES.get(kind, {}).get("backend", backend)) if kind else backend


def apply_mismatch(spec, kind: str):
    """The spec with the mismatch ``kind`` of :data:`MISMATCHES` made (``""``: unchanged)."""
    if not kind:
        return spec
    if kind not in MISMATCHES:
        raise ConfigError("mismatch", f"one of {sorted(MISMATCHES)}, got {kind!r}")
    change = {k: v for k, v in MISMATCHES[kind].items() if k != "backend"}
    if "rotation_rate" in change:
        change["rotation_rate"] = spec.procedure.rotation_rate * float(change["rotation_rate"])
    return spec.replace(procedure=change) if change else spec


class RollingFriction:
    """Not a candidate: the benchmark's unlisted effect. A different rolling friction μr, the sphere
    model's stand-in for particle shape, from the model's value (``off``) down to none."""

    name = "rolling_friction"
    label = "rolling friction (shape)"
    capability = "rolling_friction"

    def __init__(self, off: float = 0.5, high: float = 0.0) -> None:
        # ``high`` is the far end of the explored range from ``off``; here it lies below it
        self.parameters = (EffectParameter("rolling_friction", "material.rolling_friction", min(off, high), high,
                                           off=off),)

    def prior(self, experiment: Any) -> dict[str, UniformPrior]:
        p = self.parameters[0]
        return {p.name: UniformPrior(min(p.off, p.high), max(p.off, p.high))}

    def apply(self, spec, values: dict[str, float]):
        p = self.parameters[0]
        return spec.with_values({p.path: float(values[p.name])})


@dataclass(frozen=True)
class CaseLabel:
    """One case's truth (see the module docstring)."""

    case: str
    klass: str
    expected: str
    magnitude: str = ""
    truth_backend: str = ""
    params: dict[str, float] = field(default_factory=dict)
    effects: dict[str, float] = field(default_factory=dict)
    #: the procedure mismatch that made it (:data:`MISMATCHES`; empty: the model's own procedure)
    mismatch: str = ""

    def to_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in asdict(self).items() if v not in ("", {}) and k != "klass"}
        return {"case": self.case, "class": self.klass, **{k: v for k, v in d.items() if k != "case"}}


def write_labels(labels: list[CaseLabel], path: Path) -> None:
    path.write_text("# What made each benchmark case; a diagnosis never reads this file.\n"
                    + yaml.safe_dump({"cases": [lab.to_dict() for lab in labels]}, sort_keys=False, allow_unicode=True))


def read_labels(path: Path) -> list[CaseLabel]:
    """A labels file, checked: every entry has ``case``, ``class`` and ``expected``; errors name the
    file and the entry."""
    from calibrax.core.yamlfile import read_yaml

    path = Path(path)
    if not path.is_file():
        raise ConfigError("--labels", f"{path}: no such labels file")
    raw = read_yaml(path)
    entries = raw.get("cases") if isinstance(raw, dict) else None
    if not isinstance(entries, list) or not entries:
        raise ConfigError(str(path), "must be a mapping with a non-empty list `cases:` (see calibrax.diagnosis.benchmark.cases)")
    out, seen = [], set()
    for i, e in enumerate(entries):
        where = f"{path}: cases[{i}]"
        if not isinstance(e, dict) or not all(isinstance(e.get(k), str) and e.get(k) for k in ("case", "class", "expected")):
            raise ConfigError(where, "needs `case`, `class` and `expected` (text)")
        if e["case"] in seen:
            raise ConfigError(where, f"case {e['case']!r} appears twice")
        seen.add(e["case"])
        numbers = {}
        for key in ("params", "effects"):
            v = e.get(key) or {}
            if not isinstance(v, dict) or not all(isinstance(x, (int, float)) for x in v.values()):
                raise ConfigError(f"{where}.{key}", "a mapping of names to numbers")
            numbers[key] = {k: float(x) for k, x in v.items()}
        out.append(CaseLabel(e["case"], e["class"], e["expected"], str(e.get("magnitude", "")),
                             str(e.get("truth_backend", "")), numbers["params"], numbers["effects"],
                             str(e.get("mismatch", ""))))
    return out


def listed_and_unlisted(listed: list[tuple[str, str]]) -> list[tuple[str, dict[str, float]]]:
    """The listed+unlisted cases' truths, one per listed effect: (the listed effect's name, which is
    the right answer; the hidden effects: its parameter at the medium magnitude and the unlisted
    rolling friction). ``listed``: (effect name, parameter name) of each candidate."""
    return [(name, {pname: MAGNITUDES[pname]["medium"], "rolling_friction": ROLLING_FRICTION_TRUTH})
            for name, pname in listed if pname in MAGNITUDES]


def expected_answer(klass: str, listed: str = "") -> str:
    """The right answer of a case of class ``klass``; a listed+unlisted case's is its listed
    effect's name (``listed``)."""
    if klass == CLASS_MIXED:
        if not listed:
            raise ValueError("a listed+unlisted case's answer is its listed effect's name")
        return listed
    return {CLASS_NONE: NO_EFFECT, CLASS_UNLISTED: NONE_OF_THEM}.get(klass, klass)


def opaque_ids(n: int, seed: int) -> list[str]:
    """``n`` case ids in a shuffled order (the order of a folder tells nothing of the classes)."""
    order = np.random.default_rng(seed).permutation(n)
    return [f"case-{int(k) + 1:03d}" for k in order]


@dataclass(frozen=True)
class MeasurementNoise:
    """Relative s.d. of an FT4 repeat on top of the seed noise, independent per replicate and step:
    τ (a step's peak and curve together, and each preshear τ) 2 %, measured σ 1 %, bulk densities
    0.5 %, compressibility 5 % of its value (FT4 repeatability figures are of this order: a
    compressibility of 5 % repeats within about ±0.25 percentage points)."""

    tau: float = 0.02
    sigma: float = 0.01
    density: float = 0.005
    compressibility: float = 0.05


def write_blinded(results: list, out: Path, cell_words: dict[str, Any], noise: MeasurementNoise | None,
                  rng: np.random.Generator) -> Path:
    """Write replicate results as an ordinary experiment under ``out``'s stem, with measurement
    noise on top and a header that names the cell but nothing that made the data."""
    from calibrax.core.data.pseudo import write_experiment

    sd = ({"density": noise.density, "tau": noise.tau, "preshear": noise.tau, "sigma": noise.sigma,
           "compressibility": noise.compressibility} if noise else {})
    words = ("MADE DATA FOR A BLIND BENCHMARK, NOT MEASURED. What made it is in the benchmark's labels file, "
             "which the diagnosis does not read.")
    header = {"preshear_stress_pa": float(cell_words.get("preshear_stress_pa", math.nan)),
              "cell": {k: v for k, v in cell_words.items() if k != "preshear_stress_pa"}}
    return write_experiment(results, out, [words], header, lambda kind: _factor(rng, sd.get(kind, 0.0)))


def _factor(rng: np.random.Generator, sd: float) -> float:
    return float(1.0 + sd * rng.standard_normal()) if sd > 0 else 1.0


def cell_words(spec) -> dict[str, Any]:
    """What a blinded header says of the cell: its preset, base and preshear σ, and the cell pinned
    as it resolved (:func:`calibrax.core.data.cellpin.cell_pin`: no effect's value, not its walls'
    friction: that is one of the answers)."""
    from calibrax.core.data.cellpin import cell_pin

    g = spec.geometry
    return {"base_ribs": int(g.base_ribs), "rib_height": float(g.rib_height),
            "preshear_stress_pa": float(spec.procedure.preshear_stress), **cell_pin(spec)}
