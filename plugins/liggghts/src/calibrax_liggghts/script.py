"""The LIGGGHTS input script, data file and meshes of one FT4 shear test, written from a
:class:`~calibrax.core.sheartest.ShearCellSpec`.

Every number reaches the script through :func:`num` or :func:`integer` (finite float or int,
formatted here); no text from a configuration is ever pasted into it.

Conventions, identical to the numba_dem backend (``plugins/numba_dem``):

* σ = F / (π R_head²), F the upward force of the particles on the whole head (disc and blades);
  τ = 3T / (2π R_head³), T the torque about the axis that the bed opposes to the head's rotation;
  both averaged over each sample interval (``numerics.sample_interval``).
* rotation counted from 0 at the start of each step, recorded at the end of each sample interval;
  bed height = height of the head's lower face (the disc) above the base at that instant.
* fill: the same seeded loose lattice column as numba_dem (same radii, positions and initial
  velocities for the same seed), poured under 3 g with friction 0.1 and no rolling friction,
  until the fastest particle is below 0.02 m/s, then the material's friction and 1 g for 3 ms.
* the head's blade tips are placed half a particle diameter above the bed's highest particle,
  then a stress servo takes the head in at ≤ 0.2 m/s and consolidates the bed at the preshear σ,
  turning at the rotation rate, for at least one preshear rotation (numba_dem's rule);
  for each shear σ: (settle at the preshear σ, except the first), preshear rotation, bulk density,
  settle at the shear σ for ``settle_time``, shear rotation. Every settle after a rotation first
  turns the head back until its torque has relaxed (at most 0.05 rad), as numba_dem and YADE do.

Atom types: 1 base (and ribs), 2 lateral wall, 3 head, 4 particles while pouring, 5 particles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from calibrax.core.sheartest.packing import initial_packing
from calibrax.core.sheartest.procedure_stages import (Consolidate, Fork, InsertBlades, Pour, Rotate, Settle,
                                                      shear_test_stages)
from calibrax.core.sheartest.servo import servo_gains
from calibrax.core.sheartest import (APPROACH_CLEARANCE, APPROACH_SPEED, GRAVITY,
                                     INSERTION_STRESS_FRACTION, INSERTION_TOLERANCE_RADII, POUR_FRICTION, POUR_GRAVITY,
                                     POUR_SPEED, UNLOAD_MAX_ROTATION, ShearCellSpec, base_layer_bounds,
                                     insertion_time_limit, steady_schedule)
from calibrax.errors import SpecError

from . import mesh as meshes

__all__ = ["num", "integer", "ScriptPlan", "BenchStart", "write_inputs", "SCRIPT_NAME", "DATA_NAME"]

SCRIPT_NAME = "in.calibrax"
DATA_NAME = "particles.data"
#: the poured bed's particle heights and radii, written once after the pour
POURED_DUMP = "poured.dump"

#: the dynamic head's speed limit while settling and shearing, m/s: high enough never to act (as
#: numba_dem's: a limit that clips the head's response to contact spikes rectifies them). The pour,
#: approach, insertion and turn-back constants are every backend's (calibrax.core.sheartest.stages)
SHEAR_SPEED_LIMIT = 1.0
#: speed of the blind move of the head from its parking height to the approach height, m/s
PLACE_SPEED = 0.5

T_BASE, T_WALL, T_HEAD, T_POUR, T_PART = 1, 2, 3, 4, 5
NTYPES = 5


def num(value: object, key: str = "value") -> str:
    """A finite real number formatted for the script; :class:`SpecError` for anything else."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise SpecError(key, f"must be a finite number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise SpecError(key, f"must be a finite number, got {value!r}")
    return format(x, ".17g")


def integer(value: object, key: str = "value") -> str:
    """An integer formatted for the script; :class:`SpecError` for anything else."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise SpecError(key, f"must be an integer, got {value!r}")
    return str(int(value))


@dataclass(frozen=True)
class ScriptPlan:
    """What the parser needs to know about the written script."""

    dt: float
    sample_steps: int
    steps: tuple[tuple[str, float, int, str], ...]  # (kind, target σ, samples, file name)
    n_particles: int
    z_park: float
    vessel_radius: float
    head_area: float


@dataclass(frozen=True)
class BenchStart:
    """A state to start from instead of the pour, for ``benchmarks/dem_throughput.py``: the
    particles (SI arrays: radii (N,), positions, velocities, angular velocities (N, 3)) and the
    head (height of its lower face above the base, m; angle of its blades, rad; vertical speed,
    m/s). The script then loads them, puts the head there under the servo at the preshear σ,
    turning at the rotation rate, and runs ``warmup`` then ``steps`` steps (two ``run``s, timed by
    LIGGGHTS' "Loop time")."""

    radii: np.ndarray
    x: np.ndarray
    v: np.ndarray
    w: np.ndarray
    head_z: float
    head_phi: float
    head_vz: float
    warmup: int
    steps: int


def _matrix(values: dict[tuple[int, int], float], default: float, key: str) -> str:
    out = []
    for i in range(1, NTYPES + 1):
        for j in range(1, NTYPES + 1):
            v = values.get((i, j), values.get((j, i), default))
            out.append(num(v, key))
    return " ".join(out)


def _steps(duration: float, dt: float, multiple: int) -> int:
    """Whole multiples of ``multiple`` steps covering ``duration`` (at least one multiple)."""
    n = int(math.ceil(duration / dt / multiple - 1e-9))
    return max(1, n) * multiple


def write_inputs(spec: ShearCellSpec, workdir: Path, bench: BenchStart | None = None) -> ScriptPlan:
    """Write the data file, the STL meshes and the input script of ``spec`` into ``workdir``.

    ``spec`` must already be validated. Returns the :class:`ScriptPlan` the parser uses. With
    ``bench``, the script is the throughput benchmark's preshear workload instead of the shear test
    (the same cell, materials, head and servo; see :class:`BenchStart`).
    """
    g, m, p, n = spec.geometry, spec.material, spec.procedure, spec.numerics
    workdir = Path(workdir)
    dt = spec.time_step
    r = spec.radius
    d = 2.0 * r
    rc = g.vessel_diameter / 2.0
    area = math.pi * g.head_radius**2
    per = max(1, int(round(n.sample_interval / dt)))

    # ---------------------------------------------------------------- particles (numba_dem's)
    if bench is None:
        radii, x, v = initial_packing(spec)
        w = np.zeros_like(v)
        ptype = T_POUR
    else:
        radii, x, v, w = (np.asarray(a, dtype=float) for a in (bench.radii, bench.x, bench.v, bench.w))
        ptype = T_PART
    r_max = float(radii.max())
    h0 = float(np.max(x[:, 2] + radii))
    z_park = h0 + g.blade_height + 2.0 * d  # head's parking height: blade tips above the column
    if bench is not None:
        z_park = float(bench.head_z)  # the head where the benchmark's bed has it
    z_box = z_park + 4.0 * d
    half = 1.1 * rc + 2.0 * r_max
    lines = ["calibrax LIGGGHTS particles (generated)", "",
             f"{integer(len(radii))} atoms", f"{integer(NTYPES)} atom types", "",
             f"{num(-half)} {num(half)} xlo xhi", f"{num(-half)} {num(half)} ylo yhi",
             f"{num(-2.0 * r_max)} {num(z_box)} zlo zhi", "", "Atoms", ""]
    for i in range(len(radii)):
        lines.append(f"{integer(i + 1)} {integer(ptype)} {num(2.0 * radii[i], 'radius')} "
                     f"{num(m.density, 'material.density')} {num(x[i, 0])} {num(x[i, 1])} {num(x[i, 2])}")
    lines += ["", "Velocities", ""]
    for i in range(len(radii)):
        lines.append(f"{integer(i + 1)} {num(v[i, 0])} {num(v[i, 1])} {num(v[i, 2])} "
                     f"{num(w[i, 0])} {num(w[i, 1])} {num(w[i, 2])}")
    (workdir / DATA_NAME).write_text("\n".join(lines) + "\n", encoding="ascii")

    # ---------------------------------------------------------------- meshes
    meshes.write_stl(workdir / "base.stl", meshes.base_mesh(rc, r), "base")
    meshes.write_stl(workdir / "head.stl", meshes.head_mesh(g.head_radius, g.hub_radius, g.blade_count,
                                                            g.blade_height, r), "head")
    mesh_ids = ["base"]
    if g.base_ribs > 0:
        meshes.write_stl(workdir / "ribs.stl", meshes.ribs_mesh(g.hub_radius, rc, g.base_ribs, g.rib_height), "ribs")
        mesh_ids.append("ribs")
    mesh_ids.append("head")

    # ---------------------------------------------------------------- materials
    mu_b, mur_b = spec.effective_base_friction()
    mu_h = spec.effective_head_friction()
    mur_wall = spec.effective_wall_rolling_friction()
    friction = _matrix({(T_POUR, T_POUR): POUR_FRICTION, (T_POUR, T_PART): POUR_FRICTION,
                        (T_POUR, T_BASE): POUR_FRICTION, (T_POUR, T_WALL): min(g.wall_friction, POUR_FRICTION),
                        (T_POUR, T_HEAD): POUR_FRICTION,
                        (T_PART, T_PART): m.sliding_friction, (T_PART, T_BASE): mu_b,
                        (T_PART, T_WALL): g.wall_friction, (T_PART, T_HEAD): mu_h}, 0.0, "friction")
    rolling = _matrix({(T_PART, T_PART): m.rolling_friction, (T_PART, T_BASE): mur_b,
                       (T_PART, T_WALL): mur_wall, (T_PART, T_HEAD): m.rolling_friction}, 0.0, "rolling_friction")
    cohesive = spec.is_cohesive()
    # LIGGGHTS wants the keywords in this order: model, tangential, cohesion, rolling_friction
    model = ("model hertz tangential history" + (" cohesion sjkr" if cohesive else "")
             + " rolling_friction epsd2")
    E = num(m.youngs_modulus, "material.youngs_modulus")
    nu = num(m.poisson_ratio, "material.poisson_ratio")
    e = num(m.restitution, "material.restitution")

    # ---------------------------------------------------------------- servo
    # numba_dem's dynamic head (``calibrax.core.sheartest.servo``). It replaced a kinematic PI servo
    # (v = K_p e + K_i ∫e): the blades' friction reverses with the head's motion, so the force that
    # servo read depended on the direction it moved the head; it chattered, its integral wound up and,
    # at μr ≤ 0.1 on the quick cell, lifted the head off the bed in the first preshear
    bed_mass = float(np.sum(4.0 / 3.0 * math.pi * radii**3) * m.density)
    e_star = m.youngs_modulus / (2.0 * (1.0 - m.poisson_ratio**2))
    head_mass, head_damp, tau_ref = servo_gains(p.preshear_stress, area, r, e_star, g.fill_height, bed_mass)
    f_pre = p.preshear_stress * area

    def chunk(duration: float) -> str:
        return integer(_steps(duration, dt, per))

    s: list[str] = []
    add = s.append
    add("# calibrax FT4 shear test for LIGGGHTS 3.8 (generated; every number formatted by calibrax_liggghts)")
    add(f"# spec {spec.spec_hash()}; servo: head mass {num(head_mass)} kg, damping {num(head_damp)} N s/m, "
        f"tau_ref {num(tau_ref)} s")
    for line in ("atom_style granular", "atom_modify map array", "boundary f f f", "newton off",
                 "communicate single vel yes", "units si", "hard_particles yes"):
        add(line)
    add(f"read_data {DATA_NAME}")
    add(f"neighbor {num(0.4 * r_max)} bin")
    add("neigh_modify delay 0")
    add(f"fix m1 all property/global youngsModulus peratomtype {' '.join([E] * NTYPES)}")
    add(f"fix m2 all property/global poissonsRatio peratomtype {' '.join([nu] * NTYPES)}")
    add(f"fix m3 all property/global coefficientRestitution peratomtypepair {integer(NTYPES)} "
        f"{' '.join([e] * NTYPES * NTYPES)}")
    add(f"fix m4 all property/global coefficientFriction peratomtypepair {integer(NTYPES)} {friction}")
    add(f"fix m5 all property/global coefficientRollingFriction peratomtypepair {integer(NTYPES)} {rolling}")
    if cohesive:
        k = num(spec.sjkr_energy_density(), "material.bond_number" if m.bond_number > 0 else "material.cohesion_energy_density")
        add(f"fix m6 all property/global cohesionEnergyDensity peratomtypepair {integer(NTYPES)} "
            f"{' '.join([k] * NTYPES * NTYPES)}")
    add(f"pair_style gran {model}")
    add("pair_coeff * *")
    add(f"timestep {num(dt)}")
    add(f"fix gravi all gravity {num(GRAVITY * (POUR_GRAVITY if bench is None else 1.0))} vector 0.0 0.0 -1.0")
    add(f"fix base all mesh/surface file base.stl type {integer(T_BASE)}")
    if g.base_ribs > 0:
        add(f"fix ribs all mesh/surface file ribs.stl type {integer(T_BASE)}")
    # (the benchmark's head turned by its angle about the axis: the mesh has blade k at 2πk/n_blades)
    turn = "" if bench is None else f"rotate axis 0.0 0.0 1.0 angle {num(math.degrees(bench.head_phi % (2.0 * math.pi)))} "
    add(f"fix head all mesh/surface/stress file head.stl type {integer(T_HEAD)} {turn}move 0.0 0.0 {num(z_park)}")
    add(f"fix walls all wall/gran {model} mesh n_meshes {integer(len(mesh_ids))} meshes {' '.join(mesh_ids)}")
    # the lateral wall is LIGGGHTS' exact analytic cylinder, as numba_dem's: a polygon mesh with a chord
    # sag of 1 % of r (9 µm in ``quick``) is corrugated on the contacts' scale (Hertz overlap at 15 kPa
    # ≈ 0.3 µm), which acts as friction on a wall meant to be frictionless
    add(f"fix vessel all wall/gran {model} primitive type {integer(T_WALL)} zcylinder {num(rc)} 0.0 0.0")
    add("fix integr all nve/sphere")
    # -- measurements
    add("compute prad all property/atom radius")
    add("variable ztopa atom z+c_prad")
    add("compute ztop all reduce update_on_run_end yes max v_ztopa")
    add("variable ztop equal c_ztop")
    add("variable speed2 atom vx*vx+vy*vy+vz*vz")
    add("compute vmax2 all reduce update_on_run_end yes max v_speed2")
    add("variable vmax equal sqrt(c_vmax2)")
    add(f"variable zh equal {num(z_park)}+f_head[9]")
    add("variable fup equal f_head[3]")
    add("variable tres equal -f_head[6]")
    add("variable stp equal step")
    add("variable mbelow atom mass*(z<v_zh)")
    add("compute mbelow all reduce update_on_run_end yes sum v_mbelow")
    add(f"variable bulk equal c_mbelow/({num(math.pi * rc * rc)}*v_zh)")
    # particles outside the vessel (escaped through a gap): counted at the end of every step
    add(f"variable outside atom (x*x+y*y)>({num(rc)}+c_prad)*({num(rc)}+c_prad)")
    add("compute nout all reduce update_on_run_end yes sum v_outside")
    add("variable nout equal c_nout")
    # the spin about the axis of the layer just above the base (or the ribs' tops), rad/s, sampled
    # with the head's height: it says whether the bed slid on its base (sheartest.base_slip)
    z_lo, z_hi = base_layer_bounds(spec)
    add(f"variable inlayer atom (z>={num(z_lo)})*(z<{num(z_hi)})*((x*x+y*y)>1e-18)")
    add("variable spinl atom v_inlayer*(x*vy-y*vx)/(x*x+y*y+1e-18)")
    add("compute nlayer all reduce update_on_run_end yes sum v_inlayer")
    add("compute spinsum all reduce update_on_run_end yes sum v_spinl")
    add("variable bspin equal c_spinsum/(c_nlayer+1e-30)")
    # -- head motion: vertical velocity and rotation from variables
    add("variable ftgt equal 0.0")
    add("variable vlim equal 0.0")
    add("variable vz equal 0.0")
    add("variable vzero equal 0.0")
    add("variable omega equal 0.0")
    add("fix hlin all move/mesh mesh head linear/variable v_vzero v_vzero v_vz")
    add("fix hrot all move/mesh mesh head rotate/variable origin 0.0 0.0 0.0 axis 0.0 0.0 1.0 omega v_omega")
    add("thermo_style custom step atoms ke cpu")
    add(f"thermo {integer(_steps(0.01, dt, per))}")
    add("thermo_modify lost error norm no")
    add(f'print "CALIBRAX start particles {integer(len(radii))}"')

    def servo(v0: float) -> None:
        # the dynamic head from speed v0 (m/s) at this step, see the approach below
        window = max(2, int(round(2.0 * tau_ref / dt)))
        add("variable s0 equal ${stp}")
        add("variable z0 equal ${zh}")
        add("variable nst equal step-v_s0")
        add("variable err equal v_fup-v_ftgt")
        add("fix integ all ave/time 1 1 1 v_err ave running")
        add("variable hdz equal v_zh-v_z0")
        add(f"fix hzw all ave/time 1 1 1 v_hdz ave window {integer(window)}")
        add(f"variable hvref equal (v_hdz-f_hzw)*{num(2.0 / (window * dt))}")
        add("fix hyr all ave/time 1 1 1 v_hvref ave running")
        clamp = ("v_vraw+(v_vraw<-v_vlim)*(-v_vlim-v_vraw)+(v_vraw>v_vlim)*(v_vlim-v_vraw)")
        add(f"variable vlim equal {num(SHEAR_SPEED_LIMIT)}")
        add(f"variable vraw equal {num(v0)}+(f_integ*v_nst*{num(dt)}"
            f"-{num(head_damp)}*(v_hdz-f_hyr*v_nst*{num(dt)}))/{num(head_mass)}")
        add(f"variable vz equal {clamp}")

    if bench is not None:
        # ------------------------------------------------------------ benchmark: preshear from ``bench``
        add(f"variable ftgt equal {num(f_pre)}")
        add(f"variable omega equal {num(p.rotation_rate, 'procedure.rotation_rate')}")
        servo(bench.head_vz)
        add(f"fix rec all ave/time 1 {integer(per)} {integer(per)} v_fup v_tres file bench.txt")
        add(f"run {integer(bench.warmup)}")
        add(f"run {integer(bench.steps)}")
        add('print "CALIBRAX done ${stp}"')
        (workdir / SCRIPT_NAME).write_text("\n".join(s) + "\n", encoding="ascii")
        return ScriptPlan(dt=dt, sample_steps=per, steps=(), n_particles=len(radii), z_park=z_park,
                          vessel_radius=rc, head_area=area)

    def pour(stage: Pour) -> None:
        # numba_dem's pour (core's StageRunner.pour)
        t_fall = math.sqrt(2.0 * max(h0 - g.fill_height, r) / (GRAVITY * POUR_GRAVITY))
        n_loops = int(math.ceil((10.0 * t_fall + 0.05 - 1.5 * t_fall) / 2.0e-3))
        add(f"run {chunk(1.5 * t_fall)}")
        add(f"variable ipour loop {integer(n_loops)}")
        add("label pour")
        add(f'if "${{vmax}} < {num(POUR_SPEED)}" then "jump SELF pourdone"')
        add(f"run {chunk(2.0e-3)}")
        add("next ipour")
        add("jump SELF pour")
        add("label pourdone")
        add(f"set group all type {integer(T_PART)}")
        add("unfix gravi")
        add(f"fix gravi all gravity {num(GRAVITY)} vector 0.0 0.0 -1.0")
        add(f"run {chunk(3.0e-3)}")
        add('print "CALIBRAX poured ${stp} ${ztop} ${vmax}"')
        # the poured bed's particles, for its conditioned bulk density (calibrax.core.sheartest.density)
        add(f"write_dump all custom {POURED_DUMP} z radius")

    def insert_blades(stage: InsertBlades) -> None:
        # the head placed, then the blades in (core's StageRunner.insert_blades)
        add(f"variable ztarget equal v_ztop+{num(g.blade_height + APPROACH_CLEARANCE * d)}")
        add(f"variable nplace equal {integer(per)}*floor((v_zh-v_ztarget)/{num(PLACE_SPEED * dt * per)})")
        add(f"variable vz equal {num(-PLACE_SPEED)}")
        add('if "${nplace} > 0" then "run ${nplace}"')
        add("variable vz equal 0.0")
        add('print "CALIBRAX placed ${stp} ${zh} ${ztop}"')
        # the head turns while it descends and consolidates, so that the blades cut into the bed (as the
        # FT4 does, and numba_dem and YADE)
        add(f"variable omega equal {num(p.rotation_rate, 'procedure.rotation_rate')}")
        # blade insertion (numba_dem's insert_blades): with the pour's friction and no rolling resistance
        # on every contact (the particles back in the pour's atom type), the turning head comes down at
        # APPROACH_SPEED while it carries less than INSERTION_STRESS_FRACTION of the preshear load and
        # waits while it carries more, until its face is down to the poured bed's highest particle top
        add("variable ztop0 equal ${ztop}")
        add(f"variable zgoal equal {num(INSERTION_TOLERANCE_RADII * r)}+${{ztop0}}")
        add(f"set group all type {integer(T_POUR)}")
        add(f"variable fins equal {num(INSERTION_STRESS_FRACTION * (stage.stress * area))}")
        ins_chunk = max(1, per // 8)
        n_ins = int(math.ceil(insertion_time_limit(spec, APPROACH_SPEED) / (ins_chunk * dt)))
        add(f"variable iins loop {integer(n_ins)}")
        add("label insert")
        add('if "${zh} <= ${zgoal}" then "jump SELF inserted"')
        add(f'if "${{fup}} < ${{fins}}" then "variable vz equal {num(-APPROACH_SPEED)}" else "variable vz equal 0.0"')
        add(f"run {integer(ins_chunk)}")
        add("next iins")
        add("jump SELF insert")
        add("label inserted")
        add("variable vz equal 0.0")
        add(f"set group all type {integer(T_PART)}")
        add('print "CALIBRAX inserted ${stp} ${zh} ${ztop0} ${zgoal}"')

    def consolidate(stage: Consolidate) -> None:
        add(f"variable ftgt equal {num(stage.stress * area)}")
        # approach: straight down at APPROACH_SPEED until the head carries the target load (checked every
        # eighth of a sample interval: ≤ 5 µm of travel at 0.2 m/s in quick), then the dynamic head takes
        # over at that speed. (Started earlier, its closed form below would wind up: the unloaded head
        # falls freely while the speed limit holds it back)
        add(f"variable vz equal {num(-APPROACH_SPEED)}")
        app_chunk = max(1, per // 8)
        n_app = int(math.ceil(0.3 / (app_chunk * dt)))
        add(f"variable iapp loop {integer(n_app)}")
        add("label approach")
        add(f"run {integer(app_chunk)}")
        add('if "${fup} >= ${ftgt}" then "jump SELF approached"')
        add("next iapp")
        add("jump SELF approach")
        add("label approached")
        # the head as a rigid body of mass M under the target load, with a damper on v − v_ref (numba_dem's
        # and YADE's servo, calibrax.core.sheartest.servo), integrated in closed form from the contact (t = 0, v = v0):
        #   M (v − v0) = ∫(F − F*) dt − c (Δz − ∫v_ref dt),
        # with ∫(F − F*) dt and ∫v_ref dt running sums (fix ave/time ... ave running × steps × Δt) and v_ref
        # the head's displacement high-passed over W steps: v_ref = 2 (Δz − ⟨Δz⟩_W) / (W Δt), which is v
        # for a steady drift (a window mean lags a ramp by W/2 steps); W Δt = 2 τ_ref
        servo(-APPROACH_SPEED)
        # back onto whole sample intervals (the approach ran in eighths): every later run is a whole
        # number of them, so the recording fixes sample on the same steps as the parser expects
        add(f"variable pad equal {integer(per)}-step%{integer(per)}")
        add(f'if "${{pad}} < {integer(per)}" then "run ${{pad}}"')
        # σ averaged over each 3 ms chunk (numba_dem averages the last 1 ms; this tiny bed's σ is too noisy
        # for that), the head's travel over the chunk
        add(f"fix cons all ave/time 1 {chunk(3.0e-3)} {chunk(3.0e-3)} v_fup")
        # numba_dem's rule: at least one preshear rotation of turning (and 10 ms), then until the head
        # stops sinking with σ on target; at most Procedure.consolidation_time_limit
        n_cons = int(math.ceil(p.consolidation_time_limit / 3.0e-3))
        min_chunks = max(4, int(math.ceil(p.consolidation_min_time / 3.0e-3)) + 1)
        add("variable zprev equal ${zh}")
        add("variable consok equal 0")
        add(f"variable icons loop {integer(n_cons)}")
        add("label cons")
        add(f"run {chunk(3.0e-3)}")
        add("variable dz equal abs(v_zh-v_zprev)")
        add(f"variable serr equal abs(f_cons/{num(stage.stress * area)}-1.0)")
        add(f'if "${{icons}} >= {integer(min_chunks)} && ${{dz}} < {num(0.005 * d)} && ${{serr}} < 0.05" '
            'then "variable consok equal 1" "jump SELF consdone"')
        add("variable zprev equal ${zh}")
        add("next icons")
        add("jump SELF cons")
        add("label consdone")
        add('print "CALIBRAX consolidated ${stp} ${zh} ${serr} ${consok}"')
        add("variable omega equal 0.0")
        add("unfix cons")

    steps: list[tuple[str, float, int, str]] = []

    def unload_torque() -> None:
        # numba_dem's ``unload_torque`` (and YADE's): turn back at the rotation rate, under the σ of
        # the step just run, until the torque averaged over a sample interval is ≤ 0, at most
        # UNLOAD_MAX_ROTATION; every run is a whole number of sample intervals, so f_tun is current
        j = len(steps)
        n_loops = max(1, int(math.ceil(UNLOAD_MAX_ROTATION / (p.rotation_rate * per * dt))))
        add(f"variable omega equal {num(-p.rotation_rate, 'procedure.rotation_rate')}")
        add(f"fix tun all ave/time 1 {integer(per)} {integer(per)} v_tres")
        add("variable tun equal f_tun")
        add(f'print "CALIBRAX unload {integer(j)} ${{stp}}"')
        add(f"variable iun{integer(j)} loop {integer(n_loops)}")
        add(f"label unload{integer(j)}")
        add(f"run {integer(per)}")
        add(f'if "${{tun}} <= 0.0" then "jump SELF unloaded{integer(j)}"')
        add(f"next iun{integer(j)}")
        add(f"jump SELF unload{integer(j)}")
        add(f"label unloaded{integer(j)}")
        add("unfix tun")
        add(f'print "CALIBRAX unloaded {integer(j)} ${{stp}}"')

    def settle(stress: float) -> None:
        if steps:
            unload_torque()
        add("variable omega equal 0.0")
        add(f"variable ftgt equal {num(stress * area, 'procedure stress')}")
        if p.settle_time > 0:
            add(f"run {chunk(p.settle_time)}")

    def rotate(kind: str, stress: float, rotation: float, until_steady: bool = False) -> None:
        j = len(steps)
        nsamples = max(2, int(math.ceil(rotation / p.rotation_rate / (per * dt))))
        fname = f"step_{j:02d}.txt"
        add(f"variable ftgt equal {num(stress * area, 'procedure stress')}")
        add(f"variable omega equal {num(p.rotation_rate, 'procedure.rotation_rate')}")
        add(f"fix rec all ave/time 1 {integer(per)} {integer(per)} v_fup v_tres file {fname}")
        add(f'fix recz all print {integer(per)} "${{stp}} ${{zh}} ${{bspin}}" file z_{fname} screen no')
        add(f'print "CALIBRAX begin {integer(j)} ${{stp}}"')
        if until_steady and p.preshear_max_rotation is not None:
            # numba_dem's steady preshear: the window means of τ ∝ torque and σ ∝ force over the last
            # M samples (sw1) and the last 2M (sw2; the M before: 2·sw2 − sw1), checked on
            # steady_schedule's samples, the relative drift of their ratio against the tolerance
            first, nsamples, m, every = steady_schedule(p, p.rotation_rate * per * dt)
            add(f"fix sw1 all ave/time {integer(per)} 1 {integer(per)} f_rec[1] f_rec[2] ave window {integer(m)}")
            add(f"fix sw2 all ave/time {integer(per)} 1 {integer(per)} f_rec[1] f_rec[2] ave window {integer(2 * m)}")
            add("variable mlast equal f_sw1[2]/f_sw1[1]")
            add("variable mbefore equal (2*f_sw2[2]-f_sw1[2])/(2*f_sw2[1]-f_sw1[1])")
            add("variable drift equal abs(v_mlast-v_mbefore)/abs(v_mlast)")
            add(f"run {integer(first * per)}")
            checks = (nsamples - first + every - 1) // every
            if checks > 0:
                add(f"variable ist{integer(j)} loop {integer(checks)}")
                add(f"label steady{integer(j)}")
                add(f'if "${{drift}} <= {num(p.steady_tolerance)}" then "jump SELF steadied{integer(j)}"')
                add(f"run {integer(every * per)} pre no post no")
                add(f"next ist{integer(j)}")
                add(f"jump SELF steady{integer(j)}")
                add(f"label steadied{integer(j)}")
            add("unfix sw2")
            add("unfix sw1")
        else:
            add(f"run {integer(nsamples * per)}")
        add("unfix rec")
        add("unfix recz")
        add("variable omega equal 0.0")
        add(f'print "CALIBRAX end {integer(j)} ${{stp}} ${{zh}} ${{nout}}"')
        steps.append((kind, float(stress), nsamples, fname))

    def fork(stage: Fork) -> None:
        raise SpecError("procedure.compressibility_stresses", "the LIGGGHTS backend has no compressibility test")

    preshears = 0
    # the test's stages, the same list every backend runs (calibrax.core.sheartest.procedure_stages)
    for stage in shear_test_stages(spec):
        if isinstance(stage, Settle):
            settle(stage.stress)
        elif isinstance(stage, Rotate):
            rotate(stage.kind, stage.stress, stage.rotation, stage.until_steady)
            if stage.kind == "preshear":
                add(f'print "CALIBRAX bulk {integer(preshears)} ${{bulk}}"')
                preshears += 1
        else:
            {Pour: pour, InsertBlades: insert_blades, Consolidate: consolidate, Fork: fork}[type(stage)](stage)
    add('print "CALIBRAX done ${stp}"')
    (workdir / SCRIPT_NAME).write_text("\n".join(s) + "\n", encoding="ascii")
    return ScriptPlan(dt=dt, sample_steps=per, steps=tuple(steps), n_particles=len(radii), z_park=z_park,
                      vessel_radius=rc, head_area=area)
