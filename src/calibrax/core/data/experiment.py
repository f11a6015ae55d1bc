"""Measured data: yield-locus points with replicates, and what else an FT4 user can measure.

Files (all UTF-8, lines starting with ``#`` are comments — use them to say where data came from):

* points CSV, required columns ``normal_stress_pa, peak_shear_stress_pa, replicate`` (replicate is
  an integer id of the full shear test the point belongs to); optional columns:

  - ``measured_normal_stress_pa``: σ the instrument measured at the peak (an FT4 logs it; the
    target σ stands in where it is missing);
  - ``preshear_normal_stress_pa, preshear_shear_stress_pa``: steady σ and τ of the preshear before
    the point's shear step;
  - ``bulk_density_kg_m3``: the replicate's bulk density at the preshear stress (the FT4
    compressibility test at that stress), on any row of the replicate;
  - ``conditioned_bulk_density_kg_m3``: the replicate's conditioned bulk density (CBD: the FT4's
    conditioned, split vessel's mass over its volume), on any row of the replicate;

* curves CSV (optional), columns ``replicate, normal_stress_pa, rotation_rad, shear_stress_pa``:
  the τ curve of each shear step;
* compressibility CSV (optional), columns ``replicate, normal_stress_pa, compressibility_percent``:
  the FT4 compressibility test as it exports it, the volume's change from the conditioned volume
  in % at each normal stress of the ramp (e.g. 1, 2, 4, 6, 8, 10, 12, 15 kPa), increasing within
  each replicate; replicate ids are those of the points CSV (a subset of them);
* header YAML (optional) naming them, relative to itself::

      name: B4C
      source: where the data came from (instrument, date, or the pseudo-experiment's backend and parameters)
      points: b4c-points.csv
      curves: b4c-curves.csv          # optional
      compressibility: b4c-compressibility.csv   # optional
      conditioned_bulk_density_kg_m3: 1390       # optional: one CBD for every replicate (else the column)
      preshear_stress_pa: 15000       # optional
      bulk_density_kg_m3: 1470        # optional: one density for every replicate (else the column)
      wall_friction_angle_deg: 11.5   # optional: the FT4 wall friction test against the vessel's material
      cell: {preset: tiny}            # optional: the cell it was measured in, for the record; a
                                      # pseudo-experiment pins it (cellpin.cell_pin), and a preset
                                      # that no longer resolves the same is warned of on loading
      material: {sliding_friction: 0.35, youngs_modulus: 2.0e10}   # optional: known material values;
                                      # a pseudo-experiment's are its truth, which the report marks
"""

from __future__ import annotations

import csv
import dataclasses
import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from calibrax.core.data.cellpin import stale_fields
from calibrax.core.yamlfile import read_yaml
from calibrax.core.sheartest.yieldlocus import YieldLocus
from calibrax.errors import ExperimentError

POINT_COLUMNS = ("normal_stress_pa", "peak_shear_stress_pa", "replicate")
OPTIONAL_POINT_COLUMNS = ("measured_normal_stress_pa", "preshear_normal_stress_pa", "preshear_shear_stress_pa",
                          "bulk_density_kg_m3", "conditioned_bulk_density_kg_m3")
COMPRESSIBILITY_COLUMNS = ("replicate", "normal_stress_pa", "compressibility_percent")
CURVE_COLUMNS = ("replicate", "normal_stress_pa", "rotation_rad", "shear_stress_pa")
log = logging.getLogger("calibrax")
#: what the provenance of made data begins with (pseudo-experiments, the blind benchmark's cases)
MADE_DATA_MARKS = ("PSEUDO-EXPERIMENT", "MADE DATA")

HEADER_KEYS = {"name", "source", "points", "curves", "preshear_stress_pa", "material", "cell", "bulk_density_kg_m3",
               "wall_friction_angle_deg", "compressibility", "conditioned_bulk_density_kg_m3"}


@dataclass(frozen=True)
class Experiment:
    """A measured yield locus, possibly replicated.

    Attributes:
        name: a label.
        normal_stress: σ of each point, shape (n,), Pa.
        peak_shear_stress: τ_peak of each point, shape (n,), Pa.
        replicate: replicate id of each point, shape (n,), int.
        preshear_stress: σ of the preshear, Pa (NaN if unknown).
        preshear_shear_stress: steady τ of the preshear per replicate (NaN if unknown), Pa.
        curves: {(replicate, σ in Pa): (rotation rad shape (m,), τ Pa shape (m,))}.
        source: the provenance text of the data.
        files: the files it was read from.
        measured_normal_stress: σ measured at each peak, shape (n,), Pa (NaN where not recorded).
        preshear_sigma, preshear_tau: steady σ and τ of the preshear before each point, shape (n,),
            Pa (NaN where not recorded).
        bulk_density: the point's replicate's bulk density at the preshear stress, shape (n,),
            kg/m³ (NaN where not measured).
        wall_friction_angle_deg: the FT4 wall friction angle against the vessel's material,
            degrees (NaN where not measured).
        material: the header's known material values ({field: value}, SI units): for a
            pseudo-experiment, the parameters that made it (its truth).
        conditioned_bulk_density: the point's replicate's conditioned bulk density, shape (n,),
            kg/m³ (NaN where not measured).
        compressibility: {replicate: (normal stresses, Pa, increasing, shape (m,); the FT4's
            compressibility at each, % of the conditioned volume, shape (m,))}.
        stale_cell: where the header pins the cell that made the data and its preset no longer
            resolves the same, one line per changed field (:func:`calibrax.core.data.cellpin.stale_fields`).
    """

    name: str
    normal_stress: np.ndarray
    peak_shear_stress: np.ndarray
    replicate: np.ndarray
    preshear_stress: float = float("nan")
    preshear_shear_stress: float = float("nan")
    curves: dict[tuple[int, float], tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    source: str = ""
    files: tuple[str, ...] = ()
    measured_normal_stress: np.ndarray | None = None
    preshear_sigma: np.ndarray | None = None
    preshear_tau: np.ndarray | None = None
    bulk_density: np.ndarray | None = None
    wall_friction_angle_deg: float = float("nan")
    material: dict[str, float] = field(default_factory=dict)
    conditioned_bulk_density: np.ndarray | None = None
    compressibility: dict[int, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    stale_cell: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        n = np.asarray(self.normal_stress).size
        for key in ("measured_normal_stress", "preshear_sigma", "preshear_tau", "bulk_density",
                    "conditioned_bulk_density"):
            value = getattr(self, key)
            object.__setattr__(self, key, np.full(n, np.nan) if value is None else np.asarray(value, dtype=float))

    @property
    def replicates(self) -> list[int]:
        return sorted(set(int(r) for r in self.replicate))

    def locus(self) -> YieldLocus:
        """The locus fitted to all points of all replicates together."""
        return YieldLocus.fit(self.normal_stress, self.peak_shear_stress)

    def replicate_loci(self) -> list[YieldLocus]:
        """One locus per replicate (replicates with < 2 distinct σ are left out)."""
        out = []
        for r in self.replicates:
            m = self.replicate == r
            if np.unique(self.normal_stress[m]).size >= 2:
                out.append(YieldLocus.fit(self.normal_stress[m], self.peak_shear_stress[m]))
        return out

    def spread(self) -> tuple[float, float]:
        """Replicate spread (sample standard deviation) of (C in Pa, AIF in degrees).

        With fewer than two replicate loci, the regression standard errors of the pooled fit
        stand in (NaN if those are undefined too).
        """
        loci = self.replicate_loci()
        if len(loci) >= 2:
            c = np.std([l.cohesion for l in loci], ddof=1)
            a = np.std([l.aif_deg for l in loci], ddof=1)
            return float(c), float(a)
        pooled = self.locus()
        return pooled.cohesion_stderr, pooled.aif_stderr_deg


def _read_csv(path: Path, required: tuple[str, ...], optional: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    if not path.is_file():
        raise ExperimentError(str(path), "file not found")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ExperimentError(str(path), f"cannot be read as UTF-8 text: {exc}") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise ExperimentError(str(path), f"has no rows; expected columns {list(required)}")
    reader = csv.DictReader(lines)
    header = [h.strip() for h in (reader.fieldnames or [])]
    missing = [c for c in required if c not in header]
    if missing:
        raise ExperimentError(str(path), f"missing column(s) {missing}; required: {list(required)}, "
                              f"optional: {list(optional)}; found: {header}")
    unknown = [c for c in header if c not in required and c not in optional]
    if unknown:
        raise ExperimentError(str(path), f"unknown column(s) {unknown}; allowed: {list(required + optional)}")
    cols: dict[str, list[float]] = {c: [] for c in header}
    for lineno, row in enumerate(reader, start=2):
        for c in header:
            raw = (row.get(c) or "").strip()
            if raw == "" and c in optional:
                cols[c].append(float("nan"))
                continue
            try:
                v = float(raw)
            except ValueError:
                raise ExperimentError(str(path), f"row {lineno}, column {c}: {raw!r} is not a number") from None
            if not math.isfinite(v):
                raise ExperimentError(str(path), f"row {lineno}, column {c}: must be finite, got {raw!r}")
            cols[c].append(v)
    return {c: np.asarray(v, dtype=float) for c, v in cols.items()}


def load_points(path: Path, name: str | None = None) -> Experiment:
    """Read a points CSV (see the module docstring)."""
    path = Path(path)
    cols = _read_csv(path, POINT_COLUMNS, OPTIONAL_POINT_COLUMNS)
    sigma, tau, rep = cols["normal_stress_pa"], cols["peak_shear_stress_pa"], cols["replicate"]
    if np.any(sigma <= 0):
        raise ExperimentError(str(path), "normal_stress_pa must be > 0 in every row")
    if np.any(rep != np.round(rep)):
        raise ExperimentError(str(path), "replicate must be an integer id in every row")
    if np.any(tau < 0):
        row = int(np.argmax(tau < 0)) + 2
        raise ExperimentError(str(path), f"peak_shear_stress_pa must be ≥ 0 (a shear tester reports the magnitude "
                              f"of the peak), got {tau[tau < 0][0]:g} in data row {row - 1}")
    if np.unique(sigma).size < 2:
        raise ExperimentError(str(path), "needs points at two or more distinct normal stresses for a yield locus")
    for col in ("measured_normal_stress_pa", "preshear_normal_stress_pa", "preshear_shear_stress_pa",
                "bulk_density_kg_m3", "conditioned_bulk_density_kg_m3"):
        values = cols.get(col)
        if values is not None and np.any(values[np.isfinite(values)] <= 0):
            raise ExperimentError(str(path), f"{col} must be > 0 where given")
    pre_sigma = cols.get("preshear_normal_stress_pa")
    pre_tau = cols.get("preshear_shear_stress_pa")
    nan = np.full(sigma.size, np.nan)
    source = "\n".join(ln.lstrip("# ").rstrip() for ln in path.read_text(encoding="utf-8").splitlines()
                       if ln.lstrip().startswith("#"))
    return Experiment(
        name=name or path.stem,
        normal_stress=sigma,
        peak_shear_stress=tau,
        replicate=rep.astype(int),
        preshear_stress=float(np.nanmean(pre_sigma)) if pre_sigma is not None and np.any(np.isfinite(pre_sigma)) else float("nan"),
        preshear_shear_stress=float(np.nanmean(pre_tau)) if pre_tau is not None and np.any(np.isfinite(pre_tau)) else float("nan"),
        source=source,
        files=(str(path),),
        measured_normal_stress=cols.get("measured_normal_stress_pa", nan),
        preshear_sigma=pre_sigma if pre_sigma is not None else nan,
        preshear_tau=pre_tau if pre_tau is not None else nan,
        bulk_density=_per_replicate(cols.get("bulk_density_kg_m3", nan), rep),
        conditioned_bulk_density=_per_replicate(cols.get("conditioned_bulk_density_kg_m3", nan), rep),
    )


def _per_replicate(values: np.ndarray, replicate: np.ndarray) -> np.ndarray:
    """Spread each replicate's value (given on any of its rows) to all its rows."""
    out = np.asarray(values, dtype=float).copy()
    for r in np.unique(replicate):
        m = replicate == r
        given = out[m][np.isfinite(out[m])]
        if given.size:
            out[m] = float(np.mean(given))
    return out


def load_curves(path: Path) -> dict[tuple[int, float], tuple[np.ndarray, np.ndarray]]:
    """Read a curves CSV → {(replicate, σ): (rotation, τ)}, each sorted by rotation."""
    cols = _read_csv(Path(path), CURVE_COLUMNS)
    out: dict[tuple[int, float], tuple[np.ndarray, np.ndarray]] = {}
    keys = sorted(set(zip(cols["replicate"].astype(int), cols["normal_stress_pa"])))
    for rep, sig in keys:
        m = (cols["replicate"] == rep) & (cols["normal_stress_pa"] == sig)
        order = np.argsort(cols["rotation_rad"][m])
        out[(int(rep), float(sig))] = (cols["rotation_rad"][m][order], cols["shear_stress_pa"][m][order])
    return out


def load_compressibility(path: Path, replicates: list[int]) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Read a compressibility CSV → {replicate: (σ in Pa, compressibility in %)}, in the file's
    order, which must be a strictly increasing ramp within each replicate. ``replicates``: the
    points CSV's replicate ids, which the file's must be among."""
    path = Path(path)
    cols = _read_csv(path, COMPRESSIBILITY_COLUMNS)
    rep, sigma, pct = cols["replicate"], cols["normal_stress_pa"], cols["compressibility_percent"]
    if np.any(rep != np.round(rep)):
        raise ExperimentError(f"{path}: replicate", "must be an integer id in every row")
    if np.any(sigma <= 0):
        raise ExperimentError(f"{path}: normal_stress_pa", "must be > 0 in every row")
    if np.any((pct < 0) | (pct >= 100)):
        raise ExperimentError(f"{path}: compressibility_percent", "must lie in [0, 100) % in every row (the volume "
                              f"lost since conditioning), got {pct[(pct < 0) | (pct >= 100)][0]:g}")
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for r in dict.fromkeys(int(x) for x in rep):
        m = rep == r
        s_r, c_r = sigma[m], pct[m]
        if r not in replicates:
            raise ExperimentError(f"{path}: replicate",
                                  f"replicate {r} is not in the points CSV; allowed: {replicates}")
        if s_r.size < 2:
            raise ExperimentError(f"{path}: normal_stress_pa", f"replicate {r} has {s_r.size} stress; a ramp needs "
                                  "at least two")
        bad = np.flatnonzero(np.diff(s_r) <= 0)
        if bad.size:
            k = int(bad[0])
            raise ExperimentError(f"{path}: normal_stress_pa", f"replicate {r}: the compressibility ramp must increase "
                                  f"row by row, but {s_r[k]:g} Pa is followed by {s_r[k + 1]:g} Pa")
        out[r] = (s_r, c_r)
    return out


def load_experiment(path: str | Path) -> Experiment:
    """Load an experiment from a points CSV or from a YAML header naming the files."""
    path = Path(path)
    if not path.is_file():
        raise ExperimentError(str(path), "file not found (give a points CSV or a YAML header)")
    if path.suffix.lower() not in (".yaml", ".yml"):
        return load_points(path)
    header = read_yaml(path, ExperimentError)
    if not isinstance(header, dict):
        raise ExperimentError(str(path), "must be a mapping with at least the key 'points'")
    unknown = set(header) - HEADER_KEYS
    if unknown:
        raise ExperimentError(f"{path}: {sorted(unknown)[0]}", f"unknown key; allowed: {sorted(HEADER_KEYS)}")
    if not isinstance(header.get("points"), str):
        raise ExperimentError(f"{path}: points", "is required: the name of the points CSV")
    exp = load_points(path.parent / header["points"], name=str(header.get("name") or path.stem))
    curves = {}
    if header.get("curves") is not None:
        if not isinstance(header["curves"], str):
            raise ExperimentError(f"{path}: curves", "must be the name of a curves CSV")
        curves = load_curves(path.parent / header["curves"])
    pre = header.get("preshear_stress_pa", exp.preshear_stress)
    if isinstance(pre, bool) or not isinstance(pre, (int, float)):
        raise ExperimentError(f"{path}: preshear_stress_pa", f"must be a number, got {pre!r}")
    if "source" in header and not isinstance(header["source"], str):
        raise ExperimentError(f"{path}: source", f"must be text, got {header['source']!r}")
    if "name" in header and not isinstance(header["name"], str):
        raise ExperimentError(f"{path}: name", f"must be text, got {header['name']!r}")
    density = exp.bulk_density
    if header.get("bulk_density_kg_m3") is not None:
        density = np.full(exp.normal_stress.size, _positive_number(path, header, "bulk_density_kg_m3"))
    conditioned = exp.conditioned_bulk_density
    if header.get("conditioned_bulk_density_kg_m3") is not None:
        conditioned = np.full(exp.normal_stress.size, _positive_number(path, header, "conditioned_bulk_density_kg_m3"))
    compressibility = {}
    if header.get("compressibility") is not None:
        if not isinstance(header["compressibility"], str):
            raise ExperimentError(f"{path}: compressibility", "must be the name of a compressibility CSV")
        compressibility = load_compressibility(path.parent / header["compressibility"], exp.replicates)
    wall_angle = float("nan")
    if header.get("wall_friction_angle_deg") is not None:
        wall_angle = _positive_number(path, header, "wall_friction_angle_deg")
        if wall_angle >= 90:
            raise ExperimentError(f"{path}: wall_friction_angle_deg", f"must lie in (0, 90) degrees, got {wall_angle}")
    material = header.get("material") or {}
    if not isinstance(material, dict) or not all(
            isinstance(k, str) and isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for k, v in material.items()):
        raise ExperimentError(f"{path}: material", f"must map material fields to numbers, got {material!r}")
    cell = header.get("cell") or {}
    if not isinstance(cell, dict):
        raise ExperimentError(f"{path}: cell", f"must be a mapping (e.g. {{preset: tiny}}), got {cell!r}")
    made = any(mark in str(header.get("source") or exp.source) for mark in MADE_DATA_MARKS)
    stale = tuple(stale_fields(cell, made))
    for line in stale:
        log.warning("%s was made with a cell that no longer resolves the same: %s", path, line)
    source = str(header.get("source") or exp.source)
    extra = tuple(str(path.parent / header[key]) for key in ("curves", "compressibility") if header.get(key))
    files = exp.files + extra + (str(path),)
    return dataclasses.replace(exp, preshear_stress=float(pre), curves=curves, source=source, files=files,
                               bulk_density=density, wall_friction_angle_deg=wall_angle,
                               conditioned_bulk_density=conditioned, compressibility=compressibility,
                               material={k: float(v) for k, v in material.items()}, stale_cell=stale)


def _positive_number(path: Path, header: dict, key: str) -> float:
    value = header[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ExperimentError(f"{path}: {key}", f"must be a finite number > 0, got {value!r}")
    return float(value)


def experiment_fingerprint(experiment: Experiment) -> str:
    """A hash of an experiment's data (points, preshear, curves, densities, wall friction angle,
    known material), not of its name, provenance text or file paths: the same measurements read
    from another folder, or from a copy, give the same fingerprint."""
    import hashlib

    h = hashlib.sha256()

    def add(value) -> None:
        h.update(np.ascontiguousarray(np.asarray(value, dtype=float)).tobytes())
        h.update(b"|")

    for arr in (experiment.normal_stress, experiment.peak_shear_stress, experiment.replicate,
                experiment.preshear_stress, experiment.preshear_shear_stress, experiment.wall_friction_angle_deg):
        add(arr)
    for name in ("measured_normal_stress", "preshear_sigma", "preshear_tau", "bulk_density"):
        value = getattr(experiment, name)
        h.update(name.encode())
        if value is not None:
            add(value)
    for key in sorted(experiment.curves):
        add(key)
        for arr in experiment.curves[key]:
            add(arr)
    h.update(json.dumps(experiment.material, sort_keys=True).encode())
    # data added after fingerprints were stored count only where present, so that an experiment
    # without them keeps the fingerprint its stores were written with
    conditioned = np.asarray(experiment.conditioned_bulk_density, dtype=float)
    if np.any(np.isfinite(conditioned)):
        h.update(b"conditioned_bulk_density")
        add(conditioned)
    for rep in sorted(experiment.compressibility):
        h.update(b"compressibility")
        add(rep)
        for arr in experiment.compressibility[rep]:
            add(arr)
    return h.hexdigest()[:16]
