"""The ``yade`` Simulator: the FT4 shear test run by the Debian ``yade`` binary.

Contact law: YADE's ``Ip2_FrictMat_FrictMat_MindlinPhys`` (restitution-based damping ``en``,
constant rolling stiffness ``krot``, rolling limit ``eta``) with
``Law2_ScGeom_MindlinPhys_Mindlin(includeMoment=True)``, its parameters converted so that they
reproduce LIGGGHTS' ``hertz`` + ``tangential history`` + ``rolling_friction epsd2`` (see
:mod:`calibrax_yade.contact` for the mapping). Remaining differences from LIGGGHTS / numba_dem:

1. damping: YADE 2023.02 derives β_n from ``en`` with Thornton et al. (2013)'s fit for a
   no-tension law (the damped normal force is clipped at zero): the same restitution as
   LIGGGHTS, but a stronger dashpot (two spheres at e = 0.3: contact +3.7 % longer, peak overlap
   −11 %);
2. (see 1) no attractive normal force at the end of a contact (LIGGGHTS: allowed), and no
   tangential dashpot (``es = 1``): YADE's, unbounded by the Coulomb limit, made a bed under the
   preshear stress unstable at the spec's time step (see :mod:`calibrax_yade.contact`);
3. the rolling stiffness k_r is a constant (EPSD2's value at the preshear stress's Hertz overlap);
4. one rolling coefficient for every contact: exact (μr R*) for equal spheres; 0.75 μr r against
   facets (LIGGGHTS μr r); a lateral wall without friction has none, as in numba_dem and
   LIGGGHTS (the script takes it off the wall's contacts every WALL_ROLLING_PERIOD steps);
   unequal spheres get a limit (r_i + r_j)²/(4 r_i r_j) times larger;
5. the cell is made of facets (polygonal vessel, fan-disc base and head), the facets carrying a
   fictitious material (ν_w = ν, E_w ≈ 1.58 E) that restores LIGGGHTS' wall stiffnesses exactly
   (YADE's facet contact uses R = 2r/3); the base is one large facet (no inner edges);
6. no SJKR cohesion (YADE's Mindlin adhesion is DMT, a different law), so ``cohesion`` is
   refused, and a base rolling friction different from the particles' is refused.

Geometry, packing (same seed → same initial particles), procedure and the σ/τ/bed-height
conventions are numba_dem's (see the package README).
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

import numpy as np
from calibrax.core.sheartest.packing import initial_packing
from calibrax.core.sheartest import (APPROACH_CLEARANCE, APPROACH_SPEED, GRAVITY,
                                     INSERTION_STRESS_FRACTION, INSERTION_TOLERANCE_RADII, MAX_SPEED, POUR_FRICTION,
                                     POUR_GRAVITY, POUR_SPEED, UNLOAD_MAX_ROTATION, Provenance,
                                     ShearCellSpec, ShearTestResult, StepRecord, base_layer_bounds,
                                     insertion_time_limit, shear_stress_from_torque, steady_schedule)
from calibrax.core.sheartest.procedure_stages import (Compress, Consolidate, Fork, InsertBlades, Pour, Rotate, Settle,
                                                      Stage, shear_test_stages)
from calibrax.errors import SimulationFailed, SpecError

from . import __version__
from .contact import SHEAR_RESTITUTION, contact_params
from .geometry import base_mesh, head_mesh, ribs_mesh, vessel_mesh
from .runner import find_yade, run_yade, script_path, write_params, yade_version

__all__ = ["YadeSimulator", "build_params", "stage_params", "stages_from_params", "SERVO_SUBSTEPS"]

#: the head's speed limit while settling and shearing, m/s: YADE's own (its head is a rigid body
#: under the target load; numba_dem's and LIGGGHTS' servos use 1 m/s). The pour, approach,
#: insertion, turn-back and escape constants are every backend's (calibrax.core.sheartest.stages)
SHEAR_SPEED_LIMIT = 0.05
#: the head's servo is updated, and force/torque sampled, every this many time steps
SERVO_SUBSTEPS = 1
#: steps between two sweeps that take the rolling resistance off the frictionless lateral wall's new
#: contacts (YADE gives every contact the same rolling limit; ~2 % of the run time at 10, and a sweep
#: every step left the same share of the head's torque on the vessel: 6.3 % against 6.4 %, quick seed 0)
WALL_ROLLING_PERIOD = 10
#: the servo's head mass as a fraction of the bed's mass, and its v_ref time constant in (estimated)
#: head–bed periods: numba_dem's (``calibrax_numba_dem.servo``: a light head, one period), which keep
#: the mean σ of each window within a few per cent (see the README's servo paragraph)
SERVO_MASS_FRACTION = 0.25
SERVO_TAU_PERIODS = 1.0
#: default timeout of one YADE run, s (override with $CALIBRAX_YADE_TIMEOUT or the constructor)
DEFAULT_TIMEOUT = 6 * 3600.0


def _flat(tris: np.ndarray) -> list[float]:
    return [float(v) for v in np.asarray(tris, dtype=float).reshape(-1)]


def build_params(spec: ShearCellSpec) -> dict:
    """Every number the YADE script needs (SI units), from a validated spec."""
    g, m, p = spec.geometry, spec.material, spec.procedure
    cp = contact_params(spec)
    radii, x, v = initial_packing(spec)
    rc = g.vessel_diameter / 2.0
    r_ref = float(np.min(radii))
    z_top = float(max(x[:, 2].max(), g.fill_height)) + 12.0 * float(radii.max()) + g.blade_height
    disc, blades = head_mesh(g.head_radius, g.hub_radius, g.blade_count, g.blade_height, r_ref)
    mu_b, _ = spec.effective_base_friction()
    return {
        "dt": spec.time_step, "gravity": GRAVITY, "pour_gravity": POUR_GRAVITY, "pour_friction": POUR_FRICTION,
        "density": m.density, "radius": spec.radius, "young": cp.young, "poisson": cp.poisson,
        "facet_young": cp.facet_young, "facet_poisson": cp.facet_poisson, "restitution": cp.restitution,
        "shear_restitution": cp.shear_restitution,
        "krot": cp.krot, "eta": cp.eta, "e_star": cp.e_star,
        "friction": m.sliding_friction, "wall_friction": g.wall_friction, "base_friction": mu_b,
        "head_friction": spec.effective_head_friction(),
        "vessel_radius": rc, "head_radius": g.head_radius, "blade_height": g.blade_height,
        "fill_height": g.fill_height, "base_layer": list(base_layer_bounds(spec)),
        "vessel_facets": _flat(vessel_mesh(rc, z_top, r_ref)), "base_facets": _flat(base_mesh(rc, r_ref)),
        "rib_facets": _flat(ribs_mesh(g.hub_radius, rc, g.base_ribs, g.rib_height)),
        "head_disc_facets": _flat(disc), "head_blade_facets": _flat(blades),
        "radii": [float(r) for r in radii], "positions": _flat(x), "velocities": _flat(v),
        "stages": stage_params(shear_test_stages(spec)),
        "rotation_rate": p.rotation_rate, "settle_time": p.settle_time,
        "steady_schedule": _steady_schedule(spec), "steady_tolerance": p.steady_tolerance,
        "insertion_stress_fraction": INSERTION_STRESS_FRACTION,
        "insertion_time_limit": insertion_time_limit(spec, APPROACH_SPEED),
        "insertion_tolerance": INSERTION_TOLERANCE_RADII * spec.radius,
        "consolidation_min_time": p.consolidation_min_time, "consolidation_time_limit": p.consolidation_time_limit,
        "sample_interval": spec.numerics.sample_interval, "servo_substeps": SERVO_SUBSTEPS,
        "servo_mass_fraction": SERVO_MASS_FRACTION, "servo_tau_periods": SERVO_TAU_PERIODS,
        "approach_speed": APPROACH_SPEED, "shear_speed_limit": SHEAR_SPEED_LIMIT,
        "approach_clearance": APPROACH_CLEARANCE, "max_speed": MAX_SPEED, "pour_speed": POUR_SPEED,
        "unload_max_rotation": UNLOAD_MAX_ROTATION,
        # the wall's rolling friction is either every contact's (YADE's one eta) or none (cleared on
        # the wall's contacts); _refuse has turned away any other value
        "wall_rolling": 1.0 if spec.effective_wall_rolling_friction() > 0 else 0.0,
        "wall_rolling_period": float(WALL_ROLLING_PERIOD),
    }


#: the stages the script runs, by the name its main() dispatches on; a Compress or a Fork (the
#: compressibility ramp) is not among them
STAGE_NAMES = {Pour: "pour", InsertBlades: "insert_blades", Consolidate: "consolidate", Settle: "settle",
               Rotate: "rotate"}
ROTATE_KINDS = ("preshear", "shear")


def stage_params(stages: tuple[Stage, ...]) -> list[dict]:
    """The stage list as the parameter file's plain data: ``{"stage": name}`` plus the stage's
    ``stress`` (Pa), and for a rotation its ``kind``, ``rotation`` (rad) and ``until_steady``
    (1.0 / 0.0: the file holds no booleans). Names and kinds come from fixed sets
    (:data:`calibrax_yade.runner.WORDS`), numbers are floats.

    Raises:
        SpecError: a stage the script cannot run (Compress, Fork: YADE has no compressibility
            test) or a rotation of another kind, naming it, before anything is written.
    """
    out = []
    for stage in stages:
        name = STAGE_NAMES.get(type(stage))
        if name is None:
            key = "procedure.compressibility_stresses" if isinstance(stage, (Compress, Fork)) else "procedure"
            raise SpecError(key, f"the yade backend cannot run a {type(stage).__name__} stage "
                                 "(it has no compressibility test)")
        rec: dict = {"stage": name}
        if not isinstance(stage, Pour):
            rec["stress"] = float(stage.stress)
        if isinstance(stage, Rotate):
            if stage.kind not in ROTATE_KINDS:
                raise SpecError("procedure", f"the yade backend records rotations of kind {ROTATE_KINDS}, "
                                             f"got {stage.kind!r}")
            rec.update(kind=stage.kind, rotation=float(stage.rotation), until_steady=1.0 if stage.until_steady else 0.0)
        out.append(rec)
    return out


def stages_from_params(records: list[dict]) -> tuple[Stage, ...]:
    """The stages a parameter file's ``stages`` list describes (:func:`stage_params` read back)."""
    by_name = {name: cls for cls, name in STAGE_NAMES.items()}
    stages: list[Stage] = []
    for rec in records:
        cls = by_name[rec["stage"]]
        if cls is Pour:
            stages.append(Pour())
        elif cls is Rotate:
            stages.append(Rotate(rec["kind"], rec["stress"], rec["rotation"], until_steady=bool(rec["until_steady"])))
        else:
            stages.append(cls(rec["stress"]))
    return tuple(stages)


def _steady_schedule(spec: ShearCellSpec) -> list[int]:
    """:func:`~calibrax.core.sheartest.steady_schedule` in the script's samples (its ``rotate``
    samples every NSUB · round(sample_interval / (Δt NSUB)) steps), or an empty list for fixed
    preshears (the parameter file holds numbers only, so not None: ``runner.check_numbers``)."""
    if spec.procedure.preshear_max_rotation is None:
        return []
    per = SERVO_SUBSTEPS * max(1, int(round(spec.numerics.sample_interval / spec.time_step / SERVO_SUBSTEPS)))
    return list(steady_schedule(spec.procedure, spec.procedure.rotation_rate * per * spec.time_step))


def _array(rec: dict, key: str, n: int) -> np.ndarray:
    a = np.asarray(rec.get(key, []), dtype=float)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"channel {key!r} has shape {a.shape} or non-finite values")
    return a


class YadeSimulator:
    """The FT4 shear test in YADE (see the module docstring and the package README).

    Args:
        executable: the yade binary (default: $CALIBRAX_YADE, else ``yade`` on PATH).
        timeout: wall-clock limit of one run, s (default: $CALIBRAX_YADE_TIMEOUT, else 6 h).

    ``simulate`` writes, under ``workdir`` only: ``params.json`` (validated numbers), the engine's
    ``ft4_shear.log`` and ``yade_stdout.log``, and ``result.json`` (or ``failure.json``).
    """

    name = "yade"

    def __init__(self, executable: str | None = None, timeout: float | None = None) -> None:
        self.executable = executable
        env_timeout = os.environ.get("CALIBRAX_YADE_TIMEOUT")
        self.timeout = float(timeout if timeout is not None else (env_timeout or DEFAULT_TIMEOUT))

    def capabilities(self) -> frozenset[str]:
        """Wall friction (facet friction), size distributions, base ribs (facets), rolling
        friction. Not cohesion: YADE's Mindlin adhesion (DMT) is not LIGGGHTS' SJKR."""
        return frozenset({"wall_friction", "size_distribution", "base_ribs", "rolling_friction"})

    def version(self) -> str:
        """``"YADE <version>"`` of the binary that would run (raises EngineNotFound if none)."""
        return yade_version(find_yade(self.executable))

    def _refuse(self, spec: ShearCellSpec) -> None:
        from calibrax.core.simulator import check_capabilities

        check_capabilities(self, spec)
        g, m = spec.geometry, spec.material
        if g.base_rolling_friction is not None and g.base_rolling_friction != m.rolling_friction:
            raise SpecError("geometry.base_rolling_friction",
                            "the yade backend uses one rolling-friction coefficient for every contact; "
                            f"leave it unset or equal to material.rolling_friction ({m.rolling_friction})")
        wall_mur = spec.effective_wall_rolling_friction()
        if wall_mur not in (0.0, m.rolling_friction):
            raise SpecError("geometry.wall_rolling_friction",
                            "the yade backend gives the lateral wall either every contact's rolling friction "
                            f"or none; set it to 0 or to material.rolling_friction ({m.rolling_friction}), "
                            f"or leave it unset, got {wall_mur}")

    def simulate(self, spec: ShearCellSpec, workdir: Path) -> ShearTestResult:
        """Run the whole test and return its result.

        Raises:
            SpecError / ConfigError: an invalid spec or an effect YADE cannot model, before any
                file is written.
            EngineNotFound: no yade binary.
            SimulationFailed: crash, NaN, blow-up, timeout (with the log tail).
        """
        spec.validate()
        self._refuse(spec)
        params = build_params(spec)
        from .runner import check_numbers

        check_numbers(params)  # before anything touches the disk
        yade = find_yade(self.executable)
        workdir = Path(workdir).resolve()
        workdir.mkdir(parents=True, exist_ok=True)
        for stale in ("result.json", "failure.json"):
            (workdir / stale).unlink(missing_ok=True)
        params_path = write_params(workdir / "params.json", params)
        threads = spec.numerics.threads
        t0 = time.perf_counter()
        log = workdir / "ft4_shear.log"
        run_yade(yade, script_path("ft4_shear.py"), params_path, workdir, threads, self.timeout, logs=(log,))
        wall = time.perf_counter() - t0
        return self._parse(spec, workdir, wall, threads)

    def _parse(self, spec: ShearCellSpec, workdir: Path, wall: float, threads: int) -> ShearTestResult:
        from .runner import log_tail

        log = workdir / "ft4_shear.log"
        try:
            out = json.loads((workdir / "result.json").read_text())
            steps = []
            # torque on the lateral wall over the head's, second half of each shear window
            # (fraction; a wall without friction should carry none)
            vessel_share = []
            area = math.pi * spec.geometry.head_radius**2
            for rec in out["steps"]:
                n = len(rec["time"])
                force = _array(rec, "force", n)
                torque = _array(rec, "torque", n)
                if rec["kind"] == "shear":
                    vessel_torque = _array(rec, "wall_torque", n)
                    vessel_share.append(float(np.mean(vessel_torque[n // 2:]) / np.mean(torque[n // 2:])))
                steps.append(StepRecord(
                    kind=str(rec["kind"]), target_stress=float(rec["target_stress"]), time=_array(rec, "time", n),
                    rotation=_array(rec, "rotation", n),
                    shear_stress=np.asarray(shear_stress_from_torque(torque, spec.geometry.head_radius), dtype=float),
                    normal_stress=force / area, bed_height=_array(rec, "head_height", n),
                    base_spin=_array(rec, "base_spin", n) if "base_spin" in rec else np.empty(0)))
            bulk = [float(b) for b in out["bulk_density"]]
            if len([s for s in steps if s.kind == "shear"]) != len(spec.procedure.shear_stresses):
                raise ValueError("missing shear steps")
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise SimulationFailed(f"unreadable YADE output: {exc}", log_tail(log, workdir / "yade_stdout.log"),
                                   kind="crash") from exc
        version = "YADE " + str(out.get("yade_version", "?"))
        prov = Provenance(backend=self.name, engine_version=f"{version} (calibrax-yade {__version__})",
                          spec_hash=spec.spec_hash(), seed=spec.numerics.seed, wall_time=wall,
                          particle_count=int(out["particles"]), threads=threads,
                          extra={"time_step": spec.time_step, "simulated_time": out.get("simulated_time"),
                                 "servo_sigma_errors": out.get("sigma_errors", []),
                                 "insertion_gap_radii": out.get("insertion_gap_radii"),
                                 "stress_area": "pi*head_radius**2", "servo_substeps": SERVO_SUBSTEPS,
                                 "servo_mass_fraction": SERVO_MASS_FRACTION, "servo_tau_periods": SERVO_TAU_PERIODS,
                                 "shear_restitution": SHEAR_RESTITUTION,
                                 "vessel_torque_fraction": float(np.mean(vessel_share)) if vessel_share else None})
        return ShearTestResult.from_steps(spec, steps, bulk, prov, list(out.get("warnings", [])))
