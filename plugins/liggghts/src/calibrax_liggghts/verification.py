"""Verification cases of LIGGGHTS' contact law, with the same signatures and return values as
``calibrax_numba_dem.verification``, so that one cross-check command can run both backends.

Each function writes a tiny LIGGGHTS script into ``workdir`` (a temporary folder by default),
runs the real ``liggghts`` binary and returns what it measured next to the theory, as a plain
dict. SI units throughout.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
from calibrax.core.sheartest.verification import CohesiveFunctionVerification
from calibrax.core.sheartest.analytic import hertz_contact_time, rolling_stop, sliding_deceleration, sliding_time

from . import mesh as meshes
from .script import integer, num
from .simulator import run_liggghts

__all__ = ["LiggghtsVerification", "hertz_contact_time", "two_sphere_collision", "sliding_on_base", "rolling_resistance",
           "pull_off"]


def two_sphere_collision(speed: float = 0.5, restitution: float = 1.0, radius: float = 0.9e-3,
                         youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                         steps_per_contact: int = 500, workdir: Path | None = None) -> dict[str, float]:
    """Head-on impact of two equal spheres at relative speed ``speed`` (m/s), no gravity, on
    LIGGGHTS with the shear test's contact model (hertz, tangential history, EPSD2).

    Returns:
        dict with ``contact_time`` (s, measured: steps with overlap × Δt), ``peak_overlap`` (m,
        largest overlap), ``hertz_contact_time`` (s, theory for e = 1), ``restitution`` (measured
        −v_rel,out / v_rel,in), ``energy_change`` ((KE_out − KE_in)/KE_in) and ``dt`` (s).
    """
    t_c = hertz_contact_time(radius, youngs_modulus, poisson_ratio, density, speed)
    dt = t_c / steps_per_contact
    gap = 0.1 * speed * t_c
    nsteps = int(3 * steps_per_contact)
    half = 4.0 * radius
    data = ["calibrax two-sphere collision", "", "2 atoms", "1 atom types", "",
            f"{num(-half)} {num(half)} xlo xhi", f"{num(-half)} {num(half)} ylo yhi",
            f"{num(-half)} {num(half)} zlo zhi", "", "Atoms", "",
            f"1 1 {num(2 * radius)} {num(density)} {num(-radius - gap)} 0 0",
            f"2 1 {num(2 * radius)} {num(density)} {num(radius + gap)} 0 0", "", "Velocities", "",
            f"1 {num(0.5 * speed)} 0 0 0 0 0", f"2 {num(-0.5 * speed)} 0 0 0 0 0"]
    script = ["atom_style granular", "atom_modify map array", "boundary f f f", "newton off",
              "communicate single vel yes", "units si", "hard_particles yes", "read_data two.data",
              f"neighbor {num(0.5 * radius)} bin", "neigh_modify delay 0",
              f"fix m1 all property/global youngsModulus peratomtype {num(youngs_modulus)}",
              f"fix m2 all property/global poissonsRatio peratomtype {num(poisson_ratio)}",
              f"fix m3 all property/global coefficientRestitution peratomtypepair 1 {num(restitution)}",
              "fix m4 all property/global coefficientFriction peratomtypepair 1 0.5",
              "fix m5 all property/global coefficientRollingFriction peratomtypepair 1 0.0",
              "pair_style gran model hertz tangential history rolling_friction epsd2",
              "pair_coeff * *", f"timestep {num(dt)}", "fix integr all nve/sphere",
              "variable stp equal step", "variable gap equal x[2]-x[1]", "variable vrel equal vx[2]-vx[1]",
              'fix out all print 1 "${stp} ${gap} ${vrel}" file two.txt screen no',
              "thermo 100000", f"run {integer(nsteps)}"]
    with tempfile.TemporaryDirectory(prefix="calibrax-liggghts-") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        wd.mkdir(parents=True, exist_ok=True)
        (wd / "two.data").write_text("\n".join(data) + "\n", encoding="ascii")
        (wd / "in.two").write_text("\n".join(script) + "\n", encoding="ascii")
        run_liggghts(wd, script="in.two", timeout_s=300, log_name="log.two", screen_name="screen.two")
        rows = np.loadtxt(wd / "two.txt", comments="#", ndmin=2)
    distance = rows[:, 1]
    in_contact = int(np.sum(distance < 2.0 * radius))
    v_out = float(rows[-1, 2])
    return {"contact_time": in_contact * dt, "peak_overlap": float(2.0 * radius - distance.min()),
            "hertz_contact_time": t_c, "restitution": v_out / speed,
            "energy_change": (v_out**2 - speed**2) / speed**2, "dt": dt}


def _rest_overlap(radius: float, mass: float, e_star: float, g: float) -> float:
    return (mass * g / (4.0 / 3.0 * e_star * math.sqrt(radius))) ** (2.0 / 3.0)


def _sphere_on_base(workdir: Path, *, radius: float, youngs_modulus: float, poisson_ratio: float, density: float,
                    restitution: float, friction: float, rolling_friction: float, g: float, dt: float,
                    velocity: tuple[float, float, float], spin: tuple[float, float, float], nsteps: int,
                    every: int) -> np.ndarray:
    """One sphere resting (at its static overlap) on a base mesh at z = 0; rows (step, vx, ωx)."""
    m = 4.0 / 3.0 * math.pi * radius**3 * density
    e_star = youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))
    z0 = radius - _rest_overlap(radius, m, e_star, g)
    half = 0.5
    data = ["calibrax sphere on base", "", "1 atoms", "1 atom types", "",
            f"{num(-half)} {num(half)} xlo xhi", f"{num(-half)} {num(half)} ylo yhi",
            f"{num(-4 * radius)} {num(8 * radius)} zlo zhi", "", "Atoms", "",
            f"1 1 {num(2 * radius)} {num(density)} 0 0 {num(z0)}", "", "Velocities", "",
            "1 " + " ".join(num(v) for v in velocity) + " " + " ".join(num(w) for w in spin)]
    meshes.write_stl(workdir / "plane.stl", meshes.base_mesh(0.45, radius), "plane")
    script = ["atom_style granular", "atom_modify map array", "boundary f f f", "newton off",
              "communicate single vel yes", "units si", "hard_particles yes", "read_data one.data",
              f"neighbor {num(0.5 * radius)} bin", "neigh_modify delay 0",
              f"fix m1 all property/global youngsModulus peratomtype {num(youngs_modulus)}",
              f"fix m2 all property/global poissonsRatio peratomtype {num(poisson_ratio)}",
              f"fix m3 all property/global coefficientRestitution peratomtypepair 1 {num(restitution)}",
              f"fix m4 all property/global coefficientFriction peratomtypepair 1 {num(friction)}",
              f"fix m5 all property/global coefficientRollingFriction peratomtypepair 1 {num(rolling_friction)}",
              "pair_style gran model hertz tangential history rolling_friction epsd2", "pair_coeff * *",
              f"timestep {num(dt)}", f"fix gravi all gravity {num(g)} vector 0.0 0.0 -1.0",
              "fix plane all mesh/surface file plane.stl type 1",
              "fix walls all wall/gran model hertz tangential history rolling_friction epsd2 mesh n_meshes 1 "
              "meshes plane",
              "fix integr all nve/sphere",
              "compute om all property/atom omegax", "compute omsum all reduce sum c_om",
              "variable stp equal step", "variable vx1 equal vx[1]", "variable wx equal c_omsum",
              f'fix out all print {integer(every)} "${{stp}} ${{vx1}} ${{wx}}" file one.txt screen no',
              "thermo 1000000", f"run {integer(nsteps)}"]
    (workdir / "one.data").write_text("\n".join(data) + "\n", encoding="ascii")
    (workdir / "in.one").write_text("\n".join(script) + "\n", encoding="ascii")
    run_liggghts(workdir, script="in.one", timeout_s=300, log_name="log.one", screen_name="screen.one")
    return np.loadtxt(workdir / "one.txt", comments="#", ndmin=2)


def sliding_on_base(friction: float = 0.5, speed: float = 0.5, radius: float = 0.9e-3,
                    youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                    restitution: float = 0.3, g: float = 9.81, dt: float = 1.0e-6,
                    workdir: Path | None = None) -> dict[str, float]:
    """A sphere launched without spin along a flat base mesh of friction ``friction``.

    While it slides, Coulomb friction decelerates it at μs·g. Returns ``deceleration`` (m/s²,
    least-squares slope of v(t) over the middle 80 % of the sliding phase), ``expected`` (μs·g)
    and ``sliding_time`` (s, theory 2 v0 / (7 μs g)).
    """
    t_slide = sliding_time(speed, friction, g)
    every = max(1, int(t_slide / dt / 200))
    with tempfile.TemporaryDirectory(prefix="calibrax-liggghts-") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        wd.mkdir(parents=True, exist_ok=True)
        rows = _sphere_on_base(wd, radius=radius, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                               density=density, restitution=restitution, friction=friction, rolling_friction=0.0,
                               g=g, dt=dt, velocity=(speed, 0.0, 0.0), spin=(0.0, 0.0, 0.0),
                               nsteps=int(math.ceil(t_slide / dt)), every=every)
    return sliding_deceleration(rows[:, 0] * dt, rows[:, 1], speed, friction, g)


def rolling_resistance(rolling_friction: float = 0.5, spin: float = 30.0, radius: float = 0.9e-3,
                       youngs_modulus: float = 25e9, poisson_ratio: float = 0.25, density: float = 3000.0,
                       restitution: float = 0.3, g: float = 9.81, dt: float = 1.0e-6,
                       workdir: Path | None = None) -> dict[str, float]:
    """A sphere spinning about a horizontal axis on a base mesh without sliding friction, with
    EPSD2 rolling resistance ``rolling_friction``: its torque saturates at μr·R·m·g, so ω falls
    linearly. Returns ``torque`` (N·m, I·|dω/dt| over the saturated phase), ``expected``
    (μr R m g) and ``peak_torque`` (N·m, largest I·|Δω/Δt| between samples).
    """
    inertia, expected, t_stop = rolling_stop(radius, density, rolling_friction, spin, g)
    nsteps = int(0.8 * t_stop / dt)
    every = max(1, nsteps // 400)
    with tempfile.TemporaryDirectory(prefix="calibrax-liggghts-") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        wd.mkdir(parents=True, exist_ok=True)
        rows = _sphere_on_base(wd, radius=radius, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                               density=density, restitution=restitution, friction=0.0,
                               rolling_friction=rolling_friction, g=g, dt=dt, velocity=(0.0, 0.0, 0.0),
                               spin=(spin, 0.0, 0.0), nsteps=nsteps, every=every)
    t = rows[:, 0] * dt
    w = rows[:, 2]
    torques = -np.diff(w) / np.diff(t) * inertia
    sel = t > 0.2 * t[-1]
    slope = np.polyfit(t[sel], w[sel], 1)[0]
    return {"torque": -float(slope) * inertia, "expected": expected, "peak_torque": float(np.max(np.abs(torques)))}


def pull_off(energy_density: float = 1.0e8, radius: float = 0.9e-3, youngs_modulus: float = 25e9,
             poisson_ratio: float = 0.25, density: float = 3000.0, steps: int = 4000,
             workdir: Path | None = None) -> dict[str, float]:
    """Two spheres with LIGGGHTS' ``cohesion sjkr`` at ``energy_density`` (J/m³) pulled apart along
    x, and a sphere pulled off a base mesh along z, each moved by ``fix move linear`` without
    damping (restitution 1: the pull-off force is a quasi-static quantity) or gravity, from three
    times the overlap of greatest attraction to open in ``steps`` steps. Returns
    ``pull_off_force`` and ``wall_pull_off_force`` (N, the largest attraction seen), and
    ``expected`` and ``wall_expected`` (N, 2/3 π³ k³ R*² / E*² with R* = R/2 and R)."""
    from calibrax.core.sheartest.cohesion import effective_modulus, sjkr_pull_off_force, sjkr_pull_off_overlap

    e_star = effective_modulus(youngs_modulus, poisson_ratio)
    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="calibrax-liggghts-") as tmp:
        wd = Path(workdir) if workdir is not None else Path(tmp)
        wd.mkdir(parents=True, exist_ok=True)
        meshes.write_stl(wd / "plane.stl", meshes.base_mesh(0.45, radius), "plane")
        for key, reff, wall in (("pull_off_force", 0.5 * radius, False), ("wall_pull_off_force", radius, True)):
            start = 3.0 * sjkr_pull_off_overlap(energy_density, reff, e_star)
            stop = -0.2 * sjkr_pull_off_overlap(energy_density, reff, e_star)
            dt = 1.0e-9
            speed = (start - stop) / (steps * dt)
            half = 4.0 * radius
            atoms = ([f"1 1 {num(2 * radius)} {num(density)} 0 0 {num(radius - start)}"] if wall else
                     [f"1 1 {num(2 * radius)} {num(density)} 0 0 0",
                      f"2 1 {num(2 * radius)} {num(density)} {num(2 * radius - start)} 0 0"])
            box = ((-0.5, 0.5), (-0.5, 0.5), (-4.0 * radius, 8.0 * radius)) if wall else ((-half, half),) * 3
            data = ["calibrax pull-off", "", f"{len(atoms)} atoms", "1 atom types", "",
                    *(f"{num(lo)} {num(hi)} {a}lo {a}hi" for (lo, hi), a in zip(box, "xyz")), "", "Atoms", "", *atoms]
            model = "model hertz tangential history cohesion sjkr"
            moving = 1 if wall else 2
            script = ["atom_style granular", "atom_modify map array", "boundary f f f", "newton off",
                      "communicate single vel yes", "units si", "hard_particles yes", "read_data pull.data",
                      f"neighbor {num(0.5 * radius)} bin", "neigh_modify delay 0",
                      f"fix m1 all property/global youngsModulus peratomtype {num(youngs_modulus)}",
                      f"fix m2 all property/global poissonsRatio peratomtype {num(poisson_ratio)}",
                      "fix m3 all property/global coefficientRestitution peratomtypepair 1 1.0",
                      "fix m4 all property/global coefficientFriction peratomtypepair 1 0.0",
                      f"fix m6 all property/global cohesionEnergyDensity peratomtypepair 1 {num(energy_density)}",
                      f"pair_style gran {model}", "pair_coeff * *", f"timestep {num(dt)}",
                      f"group mover id {integer(moving)}"]
            if wall:
                script += ["fix plane all mesh/surface file plane.stl type 1",
                           f"fix walls all wall/gran {model} mesh n_meshes 1 meshes plane",
                           f"fix pull mover move linear 0.0 0.0 {num(speed)}",
                           "variable gap equal z[1]", "variable force equal fz[1]"]
            else:
                script += ["group anchor id 1", "fix hold anchor move linear 0.0 0.0 0.0",
                           f"fix pull mover move linear {num(speed)} 0.0 0.0",
                           "variable gap equal x[2]-x[1]", "variable force equal fx[2]"]
            script += ["variable stp equal step",
                       'fix out all print 1 "${stp} ${gap} ${force}" file pull.txt screen no',
                       "thermo 1000000", f"run {integer(steps)}"]
            (wd / "pull.data").write_text("\n".join(data) + "\n", encoding="ascii")
            (wd / "in.pull").write_text("\n".join(script) + "\n", encoding="ascii")
            run_liggghts(wd, script="in.pull", timeout_s=300, log_name="log.pull", screen_name="screen.pull")
            rows = np.loadtxt(wd / "pull.txt", comments="#", ndmin=2)
            out[key] = float(np.max(-rows[:, 2]))
    out["expected"] = sjkr_pull_off_force(energy_density, 0.5 * radius, e_star)
    out["wall_expected"] = sjkr_pull_off_force(energy_density, radius, e_star)
    return out


class LiggghtsVerification(CohesiveFunctionVerification):
    """liggghts's analytic checks for the crosscheck (:class:`calibrax.core.sheartest.verification.Verification`)."""

    name = "liggghts"
    known_differences = {}
    collision = staticmethod(two_sphere_collision)
    sliding = staticmethod(sliding_on_base)
    rolling = staticmethod(rolling_resistance)
    pull_off = staticmethod(pull_off)
