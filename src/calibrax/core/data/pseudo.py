"""Pseudo-experiments: a backend run at known parameters with several seeds (the "replicates"),
written in the experiment format (header YAML, points CSV, curves CSV) with everything an FT4 user
can measure besides the peaks: σ at each peak, the preshears' steady σ and τ, the bulk density at
the preshear stress, every shear step's τ curve, and where the backend measured them the
conditioned bulk density and the compressibility ramp.

Made data is never presented as measured: the header and both CSVs begin with a provenance block
naming the backend, its version, the cell, the spec hash, the material and the effects switched
on. Replicate seeds lie at or above :data:`EXPERIMENT_SEED_BASE`, where no
campaign's simulation seed lies.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Callable

import yaml

from calibrax.core.data.cellpin import cell_pin
from calibrax.core.sheartest.spec import ShearCellSpec
from calibrax.core.sheartest.result import ShearTestResult
from calibrax.errors import ConfigError

#: campaign simulations draw their seeds below this; experiments made by simulation (pseudo-
#: experiments) draw theirs at or above it, so a campaign never re-runs an experiment's own replicate
EXPERIMENT_SEED_BASE = 2**30


def effects_text(spec: ShearCellSpec) -> str:
    """The effects a spec switches on, in words (for the provenance block)."""
    g, sd = spec.geometry, spec.size_distribution
    return (f"lateral wall friction = {g.wall_friction:g}; size distribution = {sd.kind}"
            + (f" (σ of ln r = {sd.sigma_log:g})" if sd.kind == "lognormal" else "")
            + (f"; Bond number = {spec.material.bond_number:g} (SJKR k = {spec.sjkr_energy_density():.4g} J/m³)"
               if spec.material.bond_number > 0
               else f"; cohesion energy density = {spec.material.cohesion_energy_density:g} J/m³"))


def _simulate(simulator_name: str, spec: ShearCellSpec) -> ShearTestResult:
    from calibrax.core.registry import get_manager

    with tempfile.TemporaryDirectory() as work:
        return get_manager().create("simulator", simulator_name).simulate(spec, Path(work))


def replicate_seeds(first_seed: int, replicates: int) -> list[int]:
    """The replicates' seeds, ``first_seed`` on; ConfigError (key ``seed``) below
    :data:`EXPERIMENT_SEED_BASE`, where a campaign's simulation could re-run a replicate."""
    if first_seed < EXPERIMENT_SEED_BASE:
        raise ConfigError("seed", f"must be ≥ {EXPERIMENT_SEED_BASE}: below it a campaign's simulation could "
                                  "re-run a replicate")
    return [first_seed + r for r in range(replicates)]


def write_pseudo_experiment(spec: ShearCellSpec, simulator_name: str, out: Path, replicates: int = 3,
                            first_seed: int = EXPERIMENT_SEED_BASE + 1000, cell_words: str = "",
                            on_result: Callable[[int, ShearTestResult], None] | None = None,
                            workers: int = 1) -> Path:
    """Run ``replicates`` seeds of ``spec`` on the backend and write ``out``.yaml and its CSVs.

    Args:
        spec: the truth (its ``numerics.seed`` is replaced by each replicate's).
        simulator_name: a registered simulator.
        out: path and stem of the files (``.yaml``/``.csv`` suffixes are dropped).
        replicates: seeds to run.
        first_seed: the first replicate's seed, ≥ EXPERIMENT_SEED_BASE.
        cell_words: how the cell was set up (preset, procedure), for the provenance.
        on_result: called with (replicate index, result) after each run (progress).
        workers: replicates run at once (separate processes).

    Returns:
        the header YAML's path.
    """
    from calibrax.core.registry import get_manager

    seeds = replicate_seeds(first_seed, replicates)
    simulator = get_manager().create("simulator", simulator_name)
    specs = [spec.replace(numerics={"seed": seed}) for seed in seeds]
    if workers > 1:
        import concurrent.futures as cf
        import multiprocessing

        with cf.ProcessPoolExecutor(min(workers, replicates), mp_context=multiprocessing.get_context("spawn")) as pool:
            results = list(pool.map(_simulate, [simulator_name] * replicates, specs))
    else:
        results = [_simulate(simulator_name, s) for s in specs]
    for r, result in enumerate(results):
        if on_result:
            on_result(r, result)
    return write_pseudo_results(spec, simulator_name, simulator.version(), seeds, results, out, cell_words)


def write_pseudo_results(spec: ShearCellSpec, simulator_name: str, version: str, seeds: list[int],
                         results: list[ShearTestResult], out: Path, cell_words: str = "") -> Path:
    """Write the replicates ``results`` (one per seed of ``seeds``, each ``spec`` at that seed, run
    by ``simulator_name`` at ``version``) as a pseudo-experiment ``out``.yaml and its CSVs, with the
    provenance that says it is made data; returns the header YAML's path."""
    g = spec.geometry
    base = f"{g.base_ribs} ribs {g.rib_height * 1e3:.2g} mm high" if g.base_ribs else "flat"
    provenance = [
        "PSEUDO-EXPERIMENT, NOT MEASURED DATA.",
        f"Made by {simulator_name} ({version}) with {cell_words or 'the ' + spec.name + ' cell'} "
        f"(base: {base}), spec hash {spec.spec_hash()} (seed 0 variant).",
        "Material: " + ", ".join(f"{k} = {v:g}" for k, v in sorted(vars(spec.material).items())),
        f"Effects: {effects_text(spec)}.",
        f"Replicates are seeds {seeds} of the same spec.",
    ]
    header = {"preshear_stress_pa": float(spec.procedure.preshear_stress),
              "cell": {"base_ribs": g.base_ribs, "rib_height": g.rib_height, "wall_friction": g.wall_friction,
                       **cell_pin(spec)},
              "material": {k: float(v) for k, v in sorted(vars(spec.material).items())}}
    return write_experiment(results, out, provenance, header)


def write_experiment(results: list[ShearTestResult], out: Path, provenance: list[str], header: dict,
                     factor: Callable[[str], float] | None = None) -> Path:
    """Write results as an experiment: ``out``.yaml (name, source, the CSVs' names, then ``header``)
    and its points and curves CSVs, each beginning with ``provenance`` as comments.

    ``factor(kind)`` scales what an instrument would measure (measurement noise): it is asked for
    ``"density"`` once per replicate, then for ``"tau"`` (a step's peak and curve),
    ``"preshear"`` (its preshear τ) and ``"sigma"`` (its measured σ) per shear step, in that order;
    then, where the result has them, for ``"density"`` once more (the conditioned bulk density)
    and for ``"compressibility"`` once per stress of the ramp after its first.

    A result with a conditioned bulk density gives the points CSV the column
    ``conditioned_bulk_density_kg_m3``; results with a compressibility ramp give a compressibility
    CSV, each replicate's series measured from its first stress (0 % there).
    """
    one = factor or (lambda kind: 1.0)
    points, curves, ramps = [], [], []
    conditioned = any(math.isfinite(r.conditioned_bulk_density) for r in results)
    for r, result in enumerate(results):
        shear = [s for s in result.steps if s.kind == "shear"]
        density = float(result.bulk_density[0]) * one("density")
        rows = []
        for k, step in enumerate(shear):
            f_tau, f_pre, f_sig = one("tau"), one("preshear"), one("sigma")
            rows.append(f"{result.target_normal_stress[k]:.6g},{result.peak_shear_stress[k] * f_tau:.6g},{r + 1},"
                        f"{result.peak_normal_stress[k] * f_sig:.6g},{result.preshear_normal_stress[k] * f_sig:.6g},"
                        f"{result.preshear_shear_stress[k] * f_pre:.6g},{density:.6g}")
            for rot, tau in zip(step.rotation, step.shear_stress):
                curves.append(f"{r + 1},{step.target_stress:.6g},{rot:.6g},{tau * f_tau:.6g}")
        if conditioned:
            cbd = result.conditioned_bulk_density * one("density")
            rows = [f"{row},{cbd:.6g}" if math.isfinite(cbd) else f"{row}," for row in rows]
        points += rows
        for i, (sigma, pct) in enumerate(zip(result.compression_stress, result.compressibility)):
            ramps.append(f"{r + 1},{sigma:.6g},{pct * (one('compressibility') if i else 1.0):.6g}")
    out = Path(out)
    out = out.with_suffix("") if out.suffix in (".yaml", ".csv") else out
    out.parent.mkdir(parents=True, exist_ok=True)
    comment = "".join(f"# {line}\n" for line in provenance)
    points_path = out.parent / f"{out.name}-points.csv"
    curves_path = out.parent / f"{out.name}-curves.csv"
    points_path.write_text(comment + "normal_stress_pa,peak_shear_stress_pa,replicate,measured_normal_stress_pa,"
                           "preshear_normal_stress_pa,preshear_shear_stress_pa,bulk_density_kg_m3"
                           + (",conditioned_bulk_density_kg_m3" if conditioned else "") + "\n"
                           + "\n".join(points) + "\n")
    curves_path.write_text(comment + "replicate,normal_stress_pa,rotation_rad,shear_stress_pa\n" + "\n".join(curves) + "\n")
    full = {"name": out.name, "source": " ".join(provenance), "points": points_path.name, "curves": curves_path.name}
    if ramps:
        ramp_path = out.parent / f"{out.name}-compressibility.csv"
        ramp_path.write_text(comment + "replicate,normal_stress_pa,compressibility_percent\n" + "\n".join(ramps) + "\n")
        full["compressibility"] = ramp_path.name
    full.update(header)
    path = out.parent / f"{out.name}.yaml"
    path.write_text(comment + yaml.safe_dump(full, sort_keys=False, allow_unicode=True))
    return path
